// The Python module `bsdfmix` (examples/README.md): include/bsdfmix/mixture.hpp's evaluator,
// sampler, blend and product over numpy arrays, and the project's own readers of mixture
// files and tables (host/io). Thin wrappers: every number comes from the header or the
// readers; nothing here evaluates a Gaussian itself.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <bsdfmix/mixture_h5.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "io/h5.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"

namespace py = pybind11;
using namespace bsdfmix;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// `bsdfmix sample`'s counter stream (host/sampling/sampling.hpp, kSampleStream), so that
// sample_counter with the defaults gives the samples of `bsdfmix sample --cpu`.
constexpr std::uint32_t kSampleStream = mix::kSampleStream;

// The arguments broadcast against each other (numpy rules), each as a C-contiguous double array.
std::vector<Array> broadcast(const std::vector<py::object>& args, std::vector<py::ssize_t>& shape) {
  const py::module_ np = py::module_::import("numpy");
  py::tuple all(args.size());
  for (std::size_t i = 0; i < args.size(); ++i) all[i] = args[i];
  const py::list b = np.attr("broadcast_arrays")(*all);
  std::vector<Array> out;
  for (const auto& x : b) out.push_back(Array::ensure(np.attr("ascontiguousarray")(x)));
  shape.assign(out[0].shape(), out[0].shape() + out[0].ndim());
  return out;
}

// An [..., 3] array of `shape` plus the channel axis.
Array rgb_array(std::vector<py::ssize_t> shape) {
  shape.push_back(3);
  return Array(shape);
}

// The samples as numpy arrays (theta, phi, pdf_omega, valid).
py::tuple sample_arrays(const std::vector<mix::Sample>& s) {
  const py::ssize_t n = py::ssize_t(s.size());
  Array theta(n), phi(n), pdf(n);
  py::array_t<bool> valid(n);
  auto t = theta.mutable_unchecked<1>(), p = phi.mutable_unchecked<1>(), d = pdf.mutable_unchecked<1>();
  auto v = valid.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < n; ++i) {
    t(i) = s[i].theta;
    p(i) = s[i].phi;
    d(i) = s[i].pdf_omega;
    v(i) = s[i].valid;
  }
  return py::make_tuple(theta, phi, pdf, valid);
}

// Rows of uniforms, [n, columns].
Array uniform_rows(const py::object& u, py::ssize_t columns) {
  Array a = Array::ensure(u);
  if (!a || a.ndim() != 2 || a.shape(1) != columns)
    throw std::invalid_argument("bsdfmix: u must be an [n, " + std::to_string(columns) + "] array of uniforms in [0, 1)");
  return a;
}

// A slice mixture from parameter arrays: weights [K], means [K, 2], covariances [K, 3]
// (s_tt, s_tp, s_pp), optional rgb [K, 3] and colour copies [K, 4, 3]; prepared.
mix::SliceMixture make_slice(const Array& w, const Array& mean, const Array& cov, double scale, const py::object& rgb,
                             const py::object& copies, double theta_o, double phi_o) {
  const py::ssize_t k = w.size();
  if (w.ndim() != 1 || mean.size() != 2 * k || cov.size() != 3 * k)
    throw std::invalid_argument("bsdfmix.SliceMixture: weights [K], means [K, 2] and covariances [K, 3] disagree");
  Array amplitudes;
  if (!rgb.is_none()) {
    amplitudes = Array::ensure(rgb);
    if (!amplitudes || amplitudes.size() != 3 * k) throw std::invalid_argument("bsdfmix.SliceMixture: rgb must be [K, 3]");
  }
  mix::SliceMixture s = mix::slice_from_arrays(std::size_t(k), w.data(), mean.data(), cov.data(),
                                               rgb.is_none() ? nullptr : amplitudes.data());
  s.theta_o = theta_o;
  s.phi_o = phi_o;
  s.scale = scale;
  if (!copies.is_none()) {
    const Array a = Array::ensure(copies);
    if (!s.has_rgb) throw std::invalid_argument("bsdfmix.SliceMixture: colour copies need rgb");
    s.set_copies(std::vector<double>(a.data(), a.data() + a.size()));
  }
  s.prepare();
  return s;
}

// One field of every component as a numpy array of `cols` columns (0: a vector).
template <typename F>
Array component_array(const std::vector<mix::Gaussian>& gs, int cols, F get) {
  std::vector<py::ssize_t> shape{py::ssize_t(gs.size())};
  if (cols) shape.push_back(cols);
  Array out(shape);
  double* p = out.mutable_data();
  for (const auto& g : gs)
    for (int c = 0; c < std::max(cols, 1); ++c) *p++ = get(g, c);
  return out;
}

mix::Domain domain_of(const py::object& d) {
  if (py::isinstance<py::str>(d)) return parse_domain(d.cast<std::string>(), "bsdfmix: domain");
  return d.cast<mix::Domain>();
}

// Module-level functions: the Jacobian, the integrand weights, wrap_phi and the uniforms.
void bind_functions(py::module_& m) {
  m.def(
      "jacobian", [](const py::object& d, const Array& theta) {
        const mix::Domain dom = domain_of(d);
        return py::vectorize([dom](double t) { return mix::jacobian(dom, t); })(theta);
      },
      py::arg("domain"), py::arg("theta"), "d(omega) = J(theta) dtheta dphi: cos(theta) (fiber) or sin(theta)");
  m.def(
      "integrand_weights",
      [](const py::object& d, std::vector<double> theta_i, std::vector<double> phi_i) {
        const std::vector<float> ones(theta_i.size() * phi_i.size(), 1.f);
        const std::vector<double> w = integrand_weights(domain_of(d), theta_i, phi_i, ones.data());
        return Array({py::ssize_t(theta_i.size()), py::ssize_t(phi_i.size())}, w.data());
      },
      py::arg("domain"), py::arg("theta_i"), py::arg("phi_i"),
      "each cell's integrand weight with f = 1, [cos theta_i] J dtheta dphi, [n_theta_i, n_phi_i] "
      "(docs/formats.md, \"Integrand weights and the Jacobian\")");
  m.def("wrap_phi", py::vectorize(&mix::wrap_phi), py::arg("phi"), "phi wrapped into [-pi, pi)");
  m.def(
      "uniforms",
      [](std::uint64_t seed, std::uint32_t stream, std::uint64_t n, std::uint64_t first) {
        Array out({py::ssize_t(n), py::ssize_t(4)});
        double* p = out.mutable_data();
        for (std::uint64_t i = 0; i < n; ++i) mix::uniforms(seed, stream, first + i, p + 4 * i);
        return out;
      },
      py::arg("seed"), py::arg("stream") = kSampleStream, py::arg("n") = 1, py::arg("first") = 0,
      "[n, 4] uniforms of samples first .. first + n - 1 of a Philox stream (the header's `uniforms`)");
}

// SliceMixture: one slice's mixture, its evaluator and sampler, and the product of two.
void bind_slice_mixture(py::module_& m) {
  py::class_<mix::SliceMixture>(m, "SliceMixture",
                                "The mixture of one omega_o slice: a density over (theta, phi), prepared "
                                "(weights normalized).")
      .def(py::init([](const Array& w, const Array& mean, const Array& cov, double scale, const py::object& rgb,
                       const py::object& copies, double theta_o, double phi_o, const std::string& map) {
             mix::SliceMixture s = make_slice(w, mean, cov, scale, rgb, copies, theta_o, phi_o);
             s.map = mix::map_from_name(map);
             return s;
           }),
           py::arg("weights"), py::arg("means"), py::arg("covariances"), py::arg("scale") = 1.0,
           py::arg("rgb") = py::none(), py::arg("copies") = py::none(), py::arg("theta_o") = 0.0,
           py::arg("phi_o") = 0.0, py::arg("map") = "theta_phi",
           "weights [K], means [K, 2] (the map's x, y: mu_theta, mu_phi on theta_phi), covariances [K, 3] "
           "(s_tt, s_tp, s_pp); optional rgb amplitudes [K, 3] and colour copies' amplitudes [K, 4, 3]; map: "
           "theta_phi, disk or cylinder (docs/formats.md, \"Maps\")")
      .def_property_readonly("map", [](const mix::SliceMixture& s) { return map_name(s.map); },
                             "the plane of the components: theta_phi, disk or cylinder")
      .def_readonly("base", &mix::SliceMixture::base,
                    "the Lambertian base's share of the mixture (disk only; 0: none; docs/formats.md, \"The base\")")
      .def_property_readonly("base_rgb", [](const mix::SliceMixture& s) { return Array(3, s.base_rgb); },
                             "the base's R, G, B amplitudes")
      .def("pdf_map", py::vectorize(&mix::SliceMixture::pdf_map), py::arg("x"), py::arg("y"),
           "density per unit of the map's (x, y) (per steradian on disk and cylinder)")
      .def_readonly("theta_o", &mix::SliceMixture::theta_o)
      .def_readonly("phi_o", &mix::SliceMixture::phi_o)
      .def_readonly("scale", &mix::SliceMixture::scale)
      .def_readonly("defensive", &mix::SliceMixture::defensive,
                    "the uniform share a sampler mixes in (the file's `defensive`; 0.1 in files without it)")
      .def_readonly("has_rgb", &mix::SliceMixture::has_rgb)
      .def_property_readonly("has_copies", [](const mix::SliceMixture& s) { return !s.colour.empty(); })
      .def("__len__", [](const mix::SliceMixture& s) { return s.components.size(); })
      .def_property_readonly("weights", [](const mix::SliceMixture& s) {
        return component_array(s.components, 0, [](const mix::Gaussian& g, int) { return g.weight; });
      })
      .def_property_readonly("means", [](const mix::SliceMixture& s) {
        return component_array(s.components, 2, [](const mix::Gaussian& g, int c) { return c ? g.mu_p : g.mu_t; });
      })
      .def_property_readonly("covariances", [](const mix::SliceMixture& s) {
        return component_array(s.components, 3,
                               [](const mix::Gaussian& g, int c) { return c == 0 ? g.s_tt : c == 1 ? g.s_tp : g.s_pp; });
      })
      .def_property_readonly("rgb", [](const mix::SliceMixture& s) -> py::object {
        if (!s.has_rgb) return py::none();
        return component_array(s.components, 3, [](const mix::Gaussian& g, int c) { return g.rgb[c]; });
      })
      .def("pdf_param", py::vectorize(&mix::SliceMixture::pdf_param), py::arg("theta"), py::arg("phi"),
           "the density over (theta, phi)")
      .def("eval_param", py::vectorize(&mix::SliceMixture::eval_param), py::arg("theta"), py::arg("phi"),
           "scale * pdf_param: the stand-in of f [cos theta] J")
      .def(
          "eval_rgb_param",
          [](const mix::SliceMixture& s, const py::object& theta, const py::object& phi) {
            std::vector<py::ssize_t> shape;
            const auto a = broadcast({theta, phi}, shape);
            Array out = rgb_array(shape);
            for (py::ssize_t i = 0; i < a[0].size(); ++i) s.eval_rgb_param(a[0].data()[i], a[1].data()[i], out.mutable_data() + 3 * i);
            return out;
          },
          py::arg("theta"), py::arg("phi"), "eval_param per channel, [..., 3]")
      .def(
          "pdf_omega",
          [](const mix::SliceMixture& s, const py::object& d, const Array& theta, const Array& phi) {
            const mix::Domain dom = domain_of(d);
            return py::vectorize([&s, dom](double t, double p) { return s.pdf_omega(dom, t, p); })(theta, phi);
          },
          py::arg("domain"), py::arg("theta"), py::arg("phi"), "density per steradian of what sample() returns")
      .def(
          "sample",
          [](const mix::SliceMixture& s, const py::object& d, const py::object& u) {
            const mix::Domain dom = domain_of(d);
            const Array a = uniform_rows(u, 3);
            std::vector<mix::Sample> out(std::size_t(a.shape(0)));
            {
              py::gil_scoped_release release;
              for (std::size_t i = 0; i < out.size(); ++i) out[i] = s.sample(dom, a.data()[3 * i], a.data()[3 * i + 1], a.data()[3 * i + 2]);
            }
            return sample_arrays(out);
          },
          py::arg("domain"), py::arg("u"),
          "samples from uniforms u [n, 3] (component, then the point): (theta, phi, pdf_omega, valid)");

  m.def(
      "product",
      [](const mix::SliceMixture& a, double rotate_a, const mix::SliceMixture& b, double keep, std::size_t max_components) {
        mix::ProductOptions o;
        o.keep = keep;
        o.max_components = max_components;
        double mass = 0, kept = 0;
        mix::SliceMixture p = mix::product(a, rotate_a, b, o, &mass, &kept);
        return py::make_tuple(p, mass, kept);
      },
      py::arg("a"), py::arg("rotate_a"), py::arg("b"), py::arg("keep") = mix::ProductOptions{}.keep,
      py::arg("max_components") = mix::ProductOptions{}.max_components,
      "a (rotated by rotate_a in phi) times b as a mixture: (SliceMixture, mass, kept share)");
}

// MixtureSet: every fitted slice on the table's grid, its blend and evaluators (sampling
// and products: bind_mixture_set_sampling).
py::class_<mix::MixtureSet> bind_mixture_set(py::module_& m) {
  py::class_<mix::MixtureSet> cls(m, "MixtureSet",
                                  "All fitted slices of a mixture file on the table's omega_o grid (load_mixture).");
  cls
      .def(py::init([](const py::object& d, bool azimuthal, std::vector<double> grid_theta_o,
                       std::vector<double> grid_phi_o, std::vector<mix::SliceMixture> slices, const std::string& map) {
             mix::MixtureSet s;
             s.domain = domain_of(d);
             s.map = parse_map(map, s.domain, "MixtureSet map");
             s.azimuthal = azimuthal;
             s.grid_theta_o = std::move(grid_theta_o);
             s.grid_phi_o = std::move(grid_phi_o);
             s.slices = std::move(slices);
             s.prepare();
             return s;
           }),
           py::arg("domain"), py::arg("azimuthal"), py::arg("grid_theta_o"), py::arg("grid_phi_o"), py::arg("slices"),
           py::arg("map") = "theta_phi")
      .def_readonly("domain", &mix::MixtureSet::domain)
      .def_property_readonly("map", [](const mix::MixtureSet& s) { return map_name(s.map); },
                             "the plane of the slices' components: theta_phi (files before format version 2), disk "
                             "(hemisphere) or cylinder (fiber)")
      .def_readonly("azimuthal", &mix::MixtureSet::azimuthal)
      .def_property_readonly("grid_theta_o", [](const mix::MixtureSet& s) { return Array(py::ssize_t(s.grid_theta_o.size()), s.grid_theta_o.data()); })
      .def_property_readonly("grid_phi_o", [](const mix::MixtureSet& s) { return Array(py::ssize_t(s.grid_phi_o.size()), s.grid_phi_o.data()); })
      .def_readonly("slices", &mix::MixtureSet::slices, "the fitted slices (copies)")
      .def_readonly("slice_of", &mix::MixtureSet::slice_of, "[theta_o x phi_o] grid -> index into slices, -1 if not fitted")
      .def("__len__", [](const mix::MixtureSet& s) { return s.slices.size(); })
      .def(
          "blend",
          [](const mix::MixtureSet& s, double theta_o, double phi_o) {
            const auto b = s.blend(theta_o, phi_o);
            return py::make_tuple(std::vector<int>(b.slice, b.slice + b.count), std::vector<double>(b.weight, b.weight + b.count), b.rotate);
          },
          py::arg("theta_o"), py::arg("phi_o"), "the slices serving omega_o: (slice indices, weights, rotate)")
      .def("defensive", py::vectorize(&mix::MixtureSet::defensive), py::arg("theta_o"), py::arg("phi_o"),
           "the uniform share for omega_o: the slices' `defensive` with their blend weights")
      .def("pdf_param", py::vectorize(&mix::MixtureSet::pdf_param), py::arg("theta_o"), py::arg("phi_o"),
           py::arg("theta"), py::arg("phi"), "density over (theta, phi) of what sample() returns for omega_o")
      .def("pdf_omega", py::vectorize(&mix::MixtureSet::pdf_omega), py::arg("theta_o"), py::arg("phi_o"),
           py::arg("theta"), py::arg("phi"), "the same per steradian")
      .def("eval_f", py::vectorize(&mix::MixtureSet::eval_f), py::arg("theta_o"), py::arg("phi_o"), py::arg("theta"),
           py::arg("phi"), "the stand-in for f (per steradian; for the hemisphere without the cosine)")
      .def(
          "eval_rgb",
          [](const mix::MixtureSet& s, const py::object& to, const py::object& po, const py::object& theta,
             const py::object& phi) {
            std::vector<py::ssize_t> shape;
            const auto a = broadcast({to, po, theta, phi}, shape);
            Array out = rgb_array(shape);
            double* o = out.mutable_data();
            for (py::ssize_t i = 0; i < a[0].size(); ++i)
              s.eval_rgb(a[0].data()[i], a[1].data()[i], a[2].data()[i], a[3].data()[i], o + 3 * i);
            return out;
          },
          py::arg("theta_o"), py::arg("phi_o"), py::arg("theta"), py::arg("phi"), "eval_f per channel, [..., 3]");
  return cls;
}

// MixtureSet's samplers, the mixture serving an omega_o, and its product with a lighting.
void bind_mixture_set_sampling(py::class_<mix::MixtureSet>& cls) {
  cls
      .def(
          "sample",
          [](const mix::MixtureSet& s, double theta_o, double phi_o, const py::object& u) {
            const Array a = uniform_rows(u, 4);
            std::vector<mix::Sample> out(std::size_t(a.shape(0)));
            {
              py::gil_scoped_release release;
              const double* p = a.data();
              for (std::size_t i = 0; i < out.size(); ++i) out[i] = s.sample(theta_o, phi_o, p[4 * i], p[4 * i + 1], p[4 * i + 2], p[4 * i + 3]);
            }
            return sample_arrays(out);
          },
          py::arg("theta_o"), py::arg("phi_o"), py::arg("u"),
          "samples for omega_o from uniforms u [n, 4] (slice, component, point): (theta, phi, pdf_omega, valid)")
      .def(
          "sample_counter",
          [](const mix::MixtureSet& s, double theta_o, double phi_o, std::uint64_t n, std::uint64_t seed,
             std::uint32_t stream, std::uint64_t first) {
            std::vector<mix::Sample> out(n);
            {
              py::gil_scoped_release release;
              for (std::uint64_t i = 0; i < n; ++i) out[i] = s.sample_counter(theta_o, phi_o, seed, stream, first + i);
            }
            return sample_arrays(out);
          },
          py::arg("theta_o"), py::arg("phi_o"), py::arg("n"), py::arg("seed") = 1, py::arg("stream") = kSampleStream,
          py::arg("first") = 0,
          "samples first .. first + n - 1 of a reproducible stream (the defaults: `bsdfmix sample --cpu`'s): "
          "(theta, phi, pdf_omega, valid)")
      .def("blended", &mix::MixtureSet::blended, py::arg("theta_o"), py::arg("phi_o"),
           "the blended mixture of omega_o as one SliceMixture in the world phi frame")
      .def("at", &mix::MixtureSet::at, py::arg("theta_o"), py::arg("phi_o"),
           "the mixture serving omega_o (blended or displaced, as the file says) as one SliceMixture in the "
           "world phi frame: what pdf_omega, eval_f and sample use")
      .def_property_readonly("interpolation",
                             [](const mix::MixtureSet& s) {
                               return s.interpolation == mix::Interpolation::Displace ? "displace" : "blend";
                             })
      .def(
          "product_with",
          [](const mix::MixtureSet& s, double theta_o, double phi_o, const mix::SliceMixture& lighting, double keep,
             std::size_t max_components) {
            mix::ProductOptions o;
            o.keep = keep;
            o.max_components = max_components;
            double mass = 0, kept = 0;
            mix::SliceMixture p = s.product_with(theta_o, phi_o, lighting, o, &mass, &kept);
            return py::make_tuple(p, mass, kept);
          },
          py::arg("theta_o"), py::arg("phi_o"), py::arg("lighting"), py::arg("keep") = mix::ProductOptions{}.keep,
          py::arg("max_components") = mix::ProductOptions{}.max_components,
          "the blended mixture times a lighting mixture: (SliceMixture, mass, kept share)");
}

// The project's readers: mixture files (load_mixture, mixture_info) and tables (Table).
void bind_files(py::module_& m) {
  m.def(
      "load_mixture",
      [](const std::string& path) {
        h5::open_file(path);  // bsdfmix's probe first: metadata that crashes HDF5 is an error, not a crash
        try {
          return mix::load_mixture_h5(path);
        } catch (const std::runtime_error& e) {
          throw InputError(e.what());  // bsdfmix.Error, as every reader of the module raises
        }
      },
      py::arg("path"),
      "a mixture file (any storage) as a prepared MixtureSet: the header loader, mix::load_mixture_h5 "
      "(include/bsdfmix/mixture_h5.hpp)");
  m.def(
      "mixture_info",
      [](const std::string& path) {
        const MixtureFile f = read_mixture_file(path);
        py::dict d;
        d["domain"] = domain_name(f.domain);
        d["map"] = map_name(f.map);
        d["azimuthal"] = f.azimuthal;
        d["storage"] = storage_name(f.storage);
        d["table_source"] = f.table_source;
        d["fit_settings"] = f.fit_settings;
        d["theta_o"] = Array(py::ssize_t(f.slices()), f.theta_o.data());
        d["phi_o"] = Array(py::ssize_t(f.slices()), f.phi_o.data());
        d["scale"] = Array(py::ssize_t(f.slices()), f.scale.data());
        d["loglik"] = Array(py::ssize_t(f.slices()), f.loglik.data());
        d["l1_rel"] = Array(py::ssize_t(f.slices()), f.l1_rel.data());
        d["defensive"] = Array(py::ssize_t(f.slices()), f.defensive.data());
        d["k"] = py::array_t<std::int32_t>(py::ssize_t(f.slices()), f.k.data());
        d["payload_bytes"] = f.payload_bytes();
        return d;
      },
      py::arg("path"),
      "a mixture file's per-slice values and attributes (dict: domain, map, azimuthal, storage, table_source, "
      "fit_settings, theta_o, phi_o, scale, loglik, l1_rel, defensive, k, payload_bytes)");

  py::class_<TableReader>(m, "Table", "A table file (docs/formats.md, \"Table file\"), read one slice at a time.")
      .def(py::init<const std::string&>(), py::arg("path"))
      .def_property_readonly("path", &TableReader::path)
      .def_property_readonly("domain", [](const TableReader& t) { return t.meta().domain; })
      .def_property_readonly("azimuthal", [](const TableReader& t) { return t.meta().azimuthal; })
      .def_property_readonly("rgb", [](const TableReader& t) { return t.meta().rgb; })
      .def_property_readonly("source", [](const TableReader& t) { return t.meta().source; })
      .def_property_readonly("theta_o", [](const TableReader& t) { return Array(py::ssize_t(t.meta().theta_o.size()), t.meta().theta_o.data()); })
      .def_property_readonly("phi_o", [](const TableReader& t) { return Array(py::ssize_t(t.meta().phi_o.size()), t.meta().phi_o.data()); })
      .def_property_readonly("theta_i", [](const TableReader& t) { return Array(py::ssize_t(t.meta().theta_i.size()), t.meta().theta_i.data()); })
      .def_property_readonly("phi_i", [](const TableReader& t) { return Array(py::ssize_t(t.meta().phi_i.size()), t.meta().phi_i.data()); })
      .def(
          "slice",
          [](const TableReader& t, std::size_t t_o, std::size_t p_o) {
            const std::vector<float> v = t.read_slice(t_o, p_o);
            const TableMeta& meta = t.meta();
            return py::array_t<float>({py::ssize_t(meta.theta_i.size()), py::ssize_t(meta.phi_i.size())}, v.data());
          },
          py::arg("t_o"), py::arg("p_o") = 0, "f of slice (t_o, p_o), float32 [n_theta_i, n_phi_i]")
      .def(
          "slice_rgb",
          [](const TableReader& t, std::size_t t_o, std::size_t p_o) {
            const std::vector<float> v = t.read_slice_rgb(t_o, p_o);
            const TableMeta& meta = t.meta();
            return py::array_t<float>({py::ssize_t(meta.theta_i.size()), py::ssize_t(meta.phi_i.size()), py::ssize_t(3)},
                                      v.data());
          },
          py::arg("t_o"), py::arg("p_o") = 0, "the rgb channel of slice (t_o, p_o), float32 [n_theta_i, n_phi_i, 3]");
}

}  // namespace

PYBIND11_MODULE(bsdfmix, m) {
  m.doc() =
      "bsdfmix's Gaussian mixtures from Python: the evaluator, sampler, blend and product of "
      "include/bsdfmix/mixture.hpp over numpy arrays, and the project's readers of mixture files and "
      "tables (docs/formats.md). Angles in radians, phi in [-pi, pi).";
  py::register_exception<bsdfmix::Error>(m, "Error", PyExc_RuntimeError);
  m.attr("SAMPLE_STREAM") = kSampleStream;
  m.attr("COPIES") = mix::kCopies;

  py::enum_<mix::Domain>(m, "Domain")
      .value("fiber", mix::Domain::Fiber)
      .value("hemisphere", mix::Domain::Hemisphere);

  bind_functions(m);
  bind_slice_mixture(m);
  py::class_<mix::MixtureSet> set = bind_mixture_set(m);
  bind_mixture_set_sampling(set);
  bind_files(m);
}
