// A full-4D table and its stand-in for the renderer: opening, checking, the memory report.
#include "render/full_f.hpp"

#include <sys/stat.h>


#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"

namespace bsdfmix {
namespace render {

namespace {

std::string file_key(const std::string& path) {
  struct stat st {};
  ::stat(path.c_str(), &st);
  return path + " " + std::to_string(st.st_size) + " " + std::to_string(st.st_mtime);
}

}  // namespace

std::unique_ptr<FullF> open_full(const std::string& table_path, const std::string& mixture_path) {
  auto out = std::make_unique<FullF>();
  out->table = std::make_unique<MappedTable>(table_path);
  const MixtureFile m = read_mixture_file(mixture_path);
  const TableMeta& meta = out->table->meta();
  if (m.domain != Domain::Fiber || m.azimuthal)
    throw InputError(mixture_path + ": the full-4D stand-in must be a fiber mixture without symmetry");
  // the axes the fit recorded from the table, as compare checks them (exactly)
  if (m.table_theta_o != meta.theta_o || m.table_phi_o != meta.phi_o)
    throw InputError(mixture_path + ": its omega_o grid is not the one of " + table_path);
  out->set = to_mixture_set(m);
  out->mixture_bytes = m.payload_bytes();
  out->mixture_slices = m.slices();
  out->key = "\ntable_4d " + file_key(table_path) + "\nmixture_4d " + file_key(mixture_path);
  return out;
}

void write_full_report(const std::string& csv, const FullF& full) {
  const MappedTable& t = *full.table;
  std::string text =
      "table_bytes,mapped_bytes,resident_bytes,peak_rss_bytes,mixture_bytes,mixture_slices,table_slices\n";
  text += std::to_string(t.table_bytes()) + "," + std::to_string(t.mapped_bytes()) + "," +
          std::to_string(t.resident_bytes()) + "," + std::to_string(peak_rss_bytes()) + "," +
          std::to_string(full.mixture_bytes) + "," + std::to_string(full.mixture_slices) + "," +
          std::to_string(t.meta().n_slices()) + "\n";
  write_text_atomic(csv, text);
  const double mib = 1048576.0;
  log_line("render: full-4D table " + format_number(double(t.mapped_bytes()) / mib, "%.0f") + " MiB mapped, " +
           format_number(double(t.resident_bytes()) / mib, "%.0f") + " MiB resident, peak RSS " +
           format_number(double(peak_rss_bytes()) / mib, "%.0f") + " MiB; its stand-in " +
           format_number(double(full.mixture_bytes) / 1024.0, "%.1f") + " KiB; wrote " + csv);
}

}  // namespace render
}  // namespace bsdfmix
