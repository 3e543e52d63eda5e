// load_and_sample: use a bsdfmix mixture file from your own C++ program.
//
//   load_and_sample MIXTURE.h5 [TABLE.h5 COMPARE.csv]
//
// It needs only include/bsdfmix/mixture.hpp, mixture_h5.hpp and the HDF5 C library. It
//  1. reads the mixture file (any storage, colour, map and interpolation) into a prepared
//     bsdfmix::mix::MixtureSet with one call, bsdfmix::mix::load_mixture_h5;
//  2. picks an outgoing direction between two fitted slices (the first grid slice of the
//     table the file does not hold, or halfway between the first two fitted slices);
//  3. evaluates the stand-in f and its colour there, and draws importance samples of it;
//  4. estimates the slice integral, integral of f [cos theta_i] d(omega_i), by Monte Carlo
//     with those samples.
// Given the table and the CSV of `bsdfmix compare MIXTURE.h5 TABLE.h5 --csv COMPARE.csv`,
// it reads the table's integral at that slice and checks its estimate of the stand-in's
// energy (its integral over the table's, minus 1) against compare's `energy` column.
// Exit status 0 when the check passes (or there is nothing to check), 1 otherwise.
#include <bsdfmix/mixture_h5.hpp>
#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace mix = bsdfmix::mix;

namespace {

// Closes an HDF5 handle when it leaves scope (for the table read below).
struct H5 {
  hid_t id;
  herr_t (*close)(hid_t);
  H5(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
    if (id < 0) throw std::runtime_error("HDF5: cannot open " + what);
  }
  ~H5() { close(id); }
  H5(const H5&) = delete;
  H5& operator=(const H5&) = delete;
};

// A whole dataset as doubles.
std::vector<double> read_doubles(hid_t group, const char* name) {
  H5 d(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose, name);
  H5 space(H5Dget_space(d.id), H5Sclose, name);
  std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.id)));
  if (H5Dread(d.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw std::runtime_error(std::string("HDF5: cannot read ") + name);
  return v;
}

// --- The table's integral at one slice -----------------------------------------------------

// Sum over the cells of slice (t, p) of f [cos theta_i] J dtheta dphi: the table's integral
// (docs/formats.md, "Integrand weights and the Jacobian").
double table_integral(const std::string& path, std::size_t t, std::size_t p, mix::Domain domain) {
  H5 file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, path);
  H5 g(H5Gopen2(file.id, "table", H5P_DEFAULT), H5Gclose, path + ": /table");
  const std::vector<double> theta_i = read_doubles(g.id, "theta_i"), phi_i = read_doubles(g.id, "phi_i");
  H5 d(H5Dopen2(g.id, "values", H5P_DEFAULT), H5Dclose, "values");
  H5 space(H5Dget_space(d.id), H5Sclose, "values");
  const hsize_t start[4] = {t, p, 0, 0}, count[4] = {1, 1, theta_i.size(), phi_i.size()};
  H5Sselect_hyperslab(space.id, H5S_SELECT_SET, start, nullptr, count, nullptr);
  H5 mem(H5Screate_simple(4, count, nullptr), H5Sclose, "memory space");
  std::vector<double> f(theta_i.size() * phi_i.size());
  if (H5Dread(d.id, H5T_NATIVE_DOUBLE, mem.id, space.id, H5P_DEFAULT, f.data()) < 0)
    throw std::runtime_error(path + ": cannot read /table/values");
  const double dt = (theta_i.back() - theta_i.front()) / double(theta_i.size() - 1);
  const double dp = (phi_i.back() - phi_i.front()) / double(phi_i.size() - 1);
  double sum = 0;
  for (std::size_t i = 0; i < theta_i.size(); ++i) {
    const double weight = mix::jacobian(domain, theta_i[i]) *
                          (domain == mix::Domain::Hemisphere ? std::cos(theta_i[i]) : 1.0) * dt * dp;
    for (std::size_t j = 0; j < phi_i.size(); ++j) sum += weight * f[i * phi_i.size() + j];
  }
  return sum;
}

// The `energy` column of compare's CSV row `slice` (docs/formats.md, "Compare").
double compare_energy(const std::string& path, std::size_t slice) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  for (std::stringstream ss(line); std::getline(ss, line, ',');) names.push_back(line);
  std::size_t col = 0;
  while (col < names.size() && names[col] != "energy") ++col;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    for (std::stringstream ss(line); std::getline(ss, line, ',');) cells.push_back(line);
    if (col < cells.size() && std::stoul(cells[0]) == slice) return std::stod(cells[col]);
  }
  throw std::runtime_error(path + ": no row for slice " + std::to_string(slice) + " with an energy column");
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc != 2 && argc != 4) {
    std::fprintf(stderr, "usage: %s MIXTURE.h5 [TABLE.h5 COMPARE.csv]\n", argv[0]);
    return 2;
  }
  const mix::MixtureSet set = mix::load_mixture_h5(argv[1]);
  const bool hemisphere = set.domain == mix::Domain::Hemisphere;
  std::printf("%s: %s domain%s, %zu fitted slices on a grid of %zu x %zu omega_o\n", argv[1],
              hemisphere ? "hemisphere" : "fiber", set.azimuthal ? ", azimuthal symmetry" : "", set.slices.size(),
              set.grid_theta_o.size(), set.grid_phi_o.size());

  // An outgoing direction between fitted slices: the first grid slice of phi_o column 0 that
  // the file does not hold, with fitted slices on both sides; else halfway between the first two.
  const std::size_t np = set.azimuthal ? 1 : set.grid_phi_o.size();
  std::size_t t_between = set.grid_theta_o.size();
  for (std::size_t t = 1; t + 1 < set.grid_theta_o.size() && t_between == set.grid_theta_o.size(); ++t) {
    bool below = false, above = false;
    for (std::size_t u = 0; u < t; ++u) below = below || set.slice_of[u * np] >= 0;
    for (std::size_t u = t + 1; u < set.grid_theta_o.size(); ++u) above = above || set.slice_of[u * np] >= 0;
    if (set.slice_of[t * np] < 0 && below && above) t_between = t;
  }
  const bool on_grid = t_between < set.grid_theta_o.size();
  const double theta_o = on_grid ? set.grid_theta_o[t_between]
                                 : 0.5 * (set.slices[0].theta_o + set.slices[std::min<std::size_t>(1, set.slices.size() - 1)].theta_o);
  // With azimuthal symmetry phi_o only rotates the slice: any value serves; else a grid column.
  const double phi_o = set.azimuthal ? 0.3 : set.grid_phi_o[0];
  const mix::MixtureSet::Blend blend = set.blend(theta_o, phi_o);
  std::printf("omega_o = (%.4f, %.4f) rad, blended from", theta_o, phi_o);
  for (int k = 0; k < blend.count; ++k)
    std::printf(" slice %d at theta_o %.4f (weight %.3f)", blend.slice[k], set.slices[blend.slice[k]].theta_o, blend.weight[k]);
  std::printf("\n");

  // Importance samples of the mixture (reproducible: seed 7 on the stream of `bsdfmix sample
  // --seed 7`, mix::kSampleStream) and the Monte
  // Carlo estimate of the slice integral: the mean of f [cos theta_i] / pdf_omega, an invalid
  // sample (theta outside the domain) counting 0.
  const std::uint64_t n = 1u << 20;
  double sum = 0, sum2 = 0, rgb_sum[3] = {0, 0, 0};
  std::uint64_t valid = 0;
  for (std::uint64_t i = 0; i < n; ++i) {
    const mix::Sample s = set.sample_counter(theta_o, phi_o, 7, mix::kSampleStream, i);
    if (!s.valid) continue;
    ++valid;
    const double cos_i = hemisphere ? std::cos(s.theta) : 1.0;
    const double x = set.eval_f(theta_o, phi_o, s.theta, s.phi) * cos_i / s.pdf_omega;
    sum += x;
    sum2 += x * x;
    double rgb[3];
    set.eval_rgb(theta_o, phi_o, s.theta, s.phi, rgb);
    for (int q = 0; q < 3; ++q) rgb_sum[q] += rgb[q] * cos_i / s.pdf_omega;
    if (i == 0)
      std::printf("sample 0: theta_i %.4f, phi_i %.4f, pdf_omega %.5g /sr, f %.5g (R, G, B %.5g, %.5g, %.5g) /sr\n",
                  s.theta, s.phi, s.pdf_omega, set.eval_f(theta_o, phi_o, s.theta, s.phi), rgb[0], rgb[1], rgb[2]);
  }
  const double mean = sum / double(n), err = std::sqrt(std::max(sum2 / double(n) - mean * mean, 0.0) / double(n));
  std::printf("%llu samples, %.2f%% valid: integral of f%s d(omega_i) = %.6g +- %.2g (R, G, B %.5g, %.5g, %.5g)\n",
              static_cast<unsigned long long>(n), 100.0 * double(valid) / double(n), hemisphere ? " cos(theta_i)" : "",
              mean, err, rgb_sum[0] / double(n), rgb_sum[1] / double(n), rgb_sum[2] / double(n));
  if (argc == 2) return 0;

  if (!on_grid) {
    std::fprintf(stderr, "every grid slice is fitted: no slice between fitted ones to compare\n");
    return 1;
  }
  const std::size_t slice = t_between * set.grid_phi_o.size();  // phi_o column 0
  const double table = table_integral(argv[2], t_between, 0, set.domain);
  const double mine = mean / table - 1, theirs = compare_energy(argv[3], slice);
  // compare integrates the stand-in by the midpoint rule over the table's cells, this program
  // by sampling: they agree within the Monte Carlo error and the rule's error (1e-3 of it).
  const double tol = 4 * err / table + 1e-3;
  const bool ok = std::abs(mine - theirs) <= tol;
  std::printf("slice %zu: table integral %.6g; energy (stand-in over table, minus 1) %.5f +- %.1e here, %.5f by "
              "bsdfmix compare: %s (tolerance %.5f)\n",
              slice, table, mine, err / table, theirs, ok ? "agree" : "DISAGREE", tol);
  return ok ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "load_and_sample: %s\n", e.what());
  return 1;
}
