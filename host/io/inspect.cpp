// Human-readable summaries of table and mixture files.
#include "io/inspect.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "core/stats.hpp"
#include "io/h5.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"

namespace bsdfmix {

namespace {

std::string axis_text(const std::vector<double>& a) {
  char buf[128];
  if (a.size() == 1) std::snprintf(buf, sizeof buf, "1 value (%.6g rad)", a[0]);
  else std::snprintf(buf, sizeof buf, "%zu cells, centers %.6g .. %.6g rad, step %.6g rad", a.size(), a.front(),
                     a.back(), axis_step(a));
  return buf;
}

std::string bytes_text(double b) {
  char buf[64];
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (b >= 1024 && u < 4) {
    b /= 1024;
    ++u;
  }
  std::snprintf(buf, sizeof buf, "%.1f %s", b, units[u]);
  return buf;
}

std::string describe_table(const std::string& path, bool check_cells) {
  TableReader r(path);
  const TableMeta& m = r.meta();
  std::ostringstream s;
  s << path << ": table\n";
  s << "  domain     " << domain_name(m.domain) << "\n";
  s << "  symmetry   " << (m.azimuthal ? "azimuthal" : "none") << "\n";
  s << "  values     [" << m.theta_o.size() << ", " << m.phi_o.size() << ", " << m.theta_i.size() << ", "
    << m.phi_i.size() << "] float32 = " << m.n_slices() * m.cells_per_slice() << " cells ("
    << bytes_text(double(m.n_slices() * m.cells_per_slice()) * 4) << ")" << (m.rgb ? ", the luminance of rgb" : "")
    << "\n";
  if (m.rgb)
    s << "  rgb        [" << m.theta_o.size() << ", " << m.phi_o.size() << ", " << m.theta_i.size() << ", "
      << m.phi_i.size() << ", 3] float32: the table has colour (f in R, G, B, linear Rec. 709)"
      << (m.negative_rgb_cells >= 0
              ? "; " + std::to_string(m.negative_rgb_cells) + " cells (" +
                    format_number(100.0 * double(m.negative_rgb_cells) / double(m.n_slices() * m.cells_per_slice()), "%.1f") +
                    "%) hold a negative channel"
              : std::string())
      << "\n";
  s << "  theta_o    " << axis_text(m.theta_o) << "\n";
  s << "  phi_o      " << axis_text(m.phi_o) << "\n";
  s << "  theta_i    " << axis_text(m.theta_i) << "\n";
  s << "  phi_i      " << axis_text(m.phi_i) << "\n";
  s << "  source     " << m.source << "\n";
  s << "  file size  " << bytes_text(double(std::filesystem::file_size(path))) << "\n";
  if (check_cells) {
    double lo = 1e300, hi = -1e300, sum = 0, integ_lo = 1e300, integ_hi = -1e300;
    std::size_t zero_slices = 0;
    // With rgb: each channel's per-slice integral (albedo), its range and mean over slices.
    double ch_lo[3] = {1e300, 1e300, 1e300}, ch_hi[3] = {-1e300, -1e300, -1e300}, ch_sum[3] = {0, 0, 0};
    std::vector<float> channel(m.cells_per_slice());
    Progress progress("inspect " + path, m.n_slices(), "slices");
    for (std::size_t t = 0; t < m.theta_o.size(); ++t)
      for (std::size_t p = 0; p < m.phi_o.size(); ++p) {
        const auto v = r.read_slice(t, p);
        const auto w = integrand_weights(m.domain, m.theta_i, m.phi_i, v.data());
        double integ = 0;
        for (double x : w) integ += x;
        for (float x : v) {
          lo = std::min(lo, double(x));
          hi = std::max(hi, double(x));
          sum += x;
        }
        if (integ == 0) ++zero_slices;
        integ_lo = std::min(integ_lo, integ);
        integ_hi = std::max(integ_hi, integ);
        if (m.rgb) {
          const auto rgb = r.read_slice_rgb(t, p);
          for (int c = 0; c < 3; ++c) {
            for (std::size_t k = 0; k < channel.size(); ++k) channel[k] = rgb[3 * k + std::size_t(c)];
            double ci = 0;
            for (double x : integrand_weights(m.domain, m.theta_i, m.phi_i, channel.data())) ci += x;
            ch_lo[c] = std::min(ch_lo[c], ci);
            ch_hi[c] = std::max(ch_hi[c], ci);
            ch_sum[c] += ci;
          }
        }
        progress.advance();
      }
    progress.finish();
    char buf[256];
    std::snprintf(buf, sizeof buf, "  cells      all valid; f in [%.6g, %.6g] sr^-1, mean %.6g\n", lo, hi,
                  sum / double(m.n_slices() * m.cells_per_slice()));
    s << buf;
    std::snprintf(buf, sizeof buf, "  integral   per slice (albedo, L_i = 1) in [%.6g, %.6g]; %zu all-zero slice(s)\n",
                  integ_lo, integ_hi, zero_slices);
    s << buf;
    if (m.rgb) {
      const double n = double(m.n_slices());
      std::snprintf(buf, sizeof buf,
                    "  colour     per-slice integral R in [%.6g, %.6g], G in [%.6g, %.6g], B in [%.6g, %.6g]; "
                    "mean (%.4g, %.4g, %.4g)\n",
                    ch_lo[0], ch_hi[0], ch_lo[1], ch_hi[1], ch_lo[2], ch_hi[2], ch_sum[0] / n, ch_sum[1] / n,
                    ch_sum[2] / n);
      s << buf;
    }
  }
  return s.str();
}

// The names of the links in a file or group, in name order.
std::vector<std::string> link_names(hid_t loc) {
  std::vector<std::string> names;
  H5Literate(loc, H5_INDEX_NAME, H5_ITER_INC, nullptr,
             [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
               static_cast<std::vector<std::string>*>(data)->push_back(name);
               return 0;
             },
             &names);
  return names;
}

std::string describe_generic(const std::string& path) {
  h5::Handle f = h5::open_file(path);
  std::ostringstream s;
  const std::vector<std::string> groups = link_names(f.get());
  const bool mixture = std::find(groups.begin(), groups.end(), "mixture") != groups.end();
  s << path << ": " << (mixture ? "mixture" : "HDF5 file (neither a table nor a mixture)") << "\n";
  for (const auto& gname : groups) {
    if (!h5::exists(f.get(), gname)) continue;
    H5O_info_t info;
#if H5_VERSION_GE(1, 12, 0)
    H5Oget_info_by_name3(f.get(), gname.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT);
#else
    H5Oget_info_by_name2(f.get(), gname.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT);
#endif
    if (info.type != H5O_TYPE_GROUP) continue;
    h5::Handle g = h5::open_group(f.get(), gname, path);
    s << "  /" << gname << "\n";
    const std::vector<std::string> members = link_names(g.get());
    for (const auto& m : members) {
      h5::Handle d(H5Dopen2(g.get(), m.c_str(), H5P_DEFAULT));
      if (!d.valid()) continue;
      s << "    " << m << " [";
      const auto dims = h5::shape(d.get());
      for (std::size_t i = 0; i < dims.size(); ++i) s << (i ? ", " : "") << dims[i];
      s << "]\n";
    }
    for (const auto& a : h5::attr_names(g.get())) {
      h5::Handle at(H5Aopen(g.get(), a.c_str(), H5P_DEFAULT));
      h5::Handle type(H5Aget_type(at.get()));
      if (H5Tget_class(type.get()) == H5T_STRING)
        s << "    @" << a << " = " << h5::read_string_attr(g.get(), a, path) << "\n";
      else if (H5Tget_class(type.get()) == H5T_FLOAT || H5Tget_class(type.get()) == H5T_INTEGER)
        s << "    @" << a << " = " << h5::read_double_attr(g.get(), a, path) << "\n";
    }
    if (gname == "mixture") {
      const MixtureFile m = read_mixture_file(path);  // validates every slice
      std::map<int, int> hist;
      for (int x : m.k) hist[x]++;
      s << "  slices     " << m.slices() << " fitted, all valid; components per slice:";
      for (auto [kk, n] : hist) s << " K=" << kk << " x" << n;
      s << (m.has_rgb() ? "\n  colour     rgb_scale: R, G, B amplitudes per component" : "\n  colour     none (grey)");
      std::size_t copied = 0;
      for (std::size_t i = 0; i < m.slices(); ++i) copied += m.slice_copies(i).empty() ? 0 : 1;
      if (copied > 0) s << "; colour copies (4 per component) on " << copied << " of " << m.slices() << " slices";
      if (!m.l1_rel.empty())
        s << "\n  l1_rel     median " << percent_text(quantile(m.l1_rel, 0.5)) << ", p90 "
          << percent_text(quantile(m.l1_rel, 0.9)) << ", max " << percent_text(quantile(m.l1_rel, 1.0));
      s << "\n  datasets   " << bytes_text(double(m.payload_bytes())) << " as stored ([S, Kmax] arrays, Kmax "
        << m.kmax << ")\n";
    }
  }
  s << "  file size  " << bytes_text(double(std::filesystem::file_size(path))) << "\n";
  return s.str();
}

}  // namespace

std::string describe_file(const std::string& path, bool check_cells) {
  h5::Handle f = h5::open_file(path);
  const bool table = h5::exists(f.get(), "table");
  f.reset();
  return table ? describe_table(path, check_cells) : describe_generic(path);
}

}  // namespace bsdfmix
