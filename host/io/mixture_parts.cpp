// The parts of a mixture file read beside its slices: the domain, the format version and
// the map, and the optional Lambertian base.
#include "io/mixture_parts.hpp"

#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/h5.hpp"

namespace bsdfmix {

// The optional base (docs/formats.md, "The base"): zeros when absent.
void read_mixture_base(hid_t id, const std::string& where, MixtureFile& m) {
  const std::size_t S = m.theta_o.size();
  m.defensive = read_mixture_defensive(id, where, S);
  m.base.assign(S, 0.0);
  m.base_rgb.assign(3 * S, 0.0);
  if (!h5::exists(id, "base")) return;
  if (m.map != Map::Disk) throw InputError(where + "/base: a base needs map 'disk', the file's is " + map_name(m.map));
  m.base = h5::read_doubles(id, "base", where);
  if (m.base.size() != S)
    throw InputError(where + "/base: length " + std::to_string(m.base.size()) + ", expected " + std::to_string(S));
  for (std::size_t s = 0; s < S; ++s)
    if (!(m.base[s] >= 0 && m.base[s] <= 1))
      throw InputError(where + "/base: slice " + std::to_string(s) + " holds " + std::to_string(m.base[s]) +
                       ", expected a share in [0, 1]");
  if (!h5::exists(id, "base_rgb")) return;
  m.base_rgb = h5::read_doubles(id, "base_rgb", where);
  if (m.base_rgb.size() != 3 * S)
    throw InputError(where + "/base_rgb: " + std::to_string(m.base_rgb.size()) + " values, expected " +
                     std::to_string(3 * S) + " ([S, 3])");
}

// The domain, the format version and the map (a file without `map` is in (theta, phi)).
void read_mixture_plane(hid_t id, const std::string& where, MixtureFile& m) {
  m.domain = parse_domain(h5::read_string_attr(id, "domain", where), where + " attribute 'domain'");
  if (h5::has_attr(id, "format_version")) {
    const std::string v = h5::read_string_attr(id, "format_version", where);
    if (v != "1" && v != std::to_string(kMixtureFormatVersion))
      throw InputError(where + " attribute 'format_version': '" + v + "' is newer than this bsdfmix reads (at most " +
                       std::to_string(kMixtureFormatVersion) + "); update bsdfmix");
  }
  if (h5::has_attr(id, "map")) m.map = parse_map(h5::read_string_attr(id, "map", where), m.domain, where + " attribute 'map'");
}

// Each slice's uniform share, in [0, 1); files written before it: 0.1 for every slice.
std::vector<double> read_mixture_defensive(hid_t id, const std::string& where, std::size_t S) {
  if (!h5::exists(id, "defensive")) return std::vector<double>(S, kDefaultDefensive);
  std::vector<double> a = h5::read_doubles(id, "defensive", where);
  if (a.size() != S)
    throw InputError(where + "/defensive: length " + std::to_string(a.size()) + ", expected " + std::to_string(S) +
                     " (the length of theta_o)");
  for (std::size_t s = 0; s < a.size(); ++s)
    if (!(a[s] >= 0 && a[s] < 1))
      throw InputError(where + " slice " + std::to_string(s) + ": defensive is not a share in [0, 1)");
  return a;
}

}  // namespace bsdfmix
