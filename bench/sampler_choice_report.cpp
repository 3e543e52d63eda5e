// `bsdfmix recommend`'s CSV and printed text (bench/sampler_choice.hpp).
#include <algorithm>
#include <cstdio>
#include <sstream>

#include "bench/sampler_choice.hpp"
#include "core/format.hpp"

namespace bsdfmix::bench {

namespace {

// A candidate as the text names it: mis_tab with its share.
std::string label(const SamplerFigure& f) {
  if (f.share.empty()) return f.sampler;
  return f.sampler + (f.share == "earned" ? " at its earned share" : " at share " + f.share);
}

// What the figures are relative to, in words.
std::string reference_words(const std::string& reference) {
  if (reference == "is_rgl") return "the file's sampler";
  if (reference == "cdf_tab") return "the table CDF";
  if (reference == "mis_light_rgl") return "light + the file's sampler";
  return "light + the table CDF";
}

std::string times(double v) { return format_number(v, v < 10 ? "%.2f" : "%.3g") + "x"; }

}  // namespace

std::string sampler_choice_csv(const SamplerChoice& c, const std::string& material) {
  std::ostringstream s;
  s << "material,lighting,sampler,share,views,samples,median_relvar,max_relvar,vs_reference,reference,bytes,"
       "recommended\n";
  for (const SamplerFigure& f : c.figures) {
    const std::size_t l = std::size_t(std::find(c.lightings.begin(), c.lightings.end(), f.lighting) - c.lightings.begin());
    s << material << ',' << f.lighting << ',' << f.sampler << ',' << f.share << ',' << c.views_deg.size() << ','
      << c.samples << ',' << format_number(f.median, "%.6g") << ',' << format_number(f.max, "%.6g") << ','
      << format_number(f.vs_reference, "%.6g") << ',' << c.references[l] << ',' << f.bytes << ','
      << (f.recommended ? 1 : 0) << '\n';
  }
  return s.str();
}

std::string sampler_choice_text(const SamplerChoice& c, const std::string& material) {
  std::ostringstream s;
  s << material << ": " << c.views_deg.size() << " view elevations from " << format_number(c.views_deg.front(), "%.1f")
    << " to " << format_number(c.views_deg.back(), "%.1f") << " degrees, " << c.samples << " samples each, "
    << format_number(c.seconds, "%.1f") << " s; variance per sample, median over the views\n";
  for (std::size_t l = 0; l < c.lightings.size(); ++l) {
    const int best = least_variance(c.figures, c.lightings[l]);
    if (best < 0) continue;
    const SamplerFigure& b = c.figures[std::size_t(best)];
    s << (l ? "with lighting (" + c.lightings[l] + ")" : std::string("BSDF only")) << ": take " << label(b) << " ("
      << times(b.vs_reference) << " " << reference_words(c.references[l]) << ", " << b.bytes << " bytes)";
    for (const SamplerFigure& f : c.figures)
      if (f.lighting == c.lightings[l] && &f != &b) s << "; " << label(f) << " is " << times(f.vs_reference);
    s << "\n";
  }
  if (c.lightings.size() < 2) s << "with lighting: give --scene SCENE.yaml (configs/scenes/) to choose\n";
  s << "lighting       sampler         share        relvar median      max    vs reference        bytes\n";
  for (const SamplerFigure& f : c.figures) {
    char line[200];
    std::snprintf(line, sizeof line, "%-14s %-15s %-12s %12.4g %12.4g %12.4g %12llu%s\n", f.lighting.c_str(),
                  f.sampler.c_str(), f.share.c_str(), f.median, f.max, f.vs_reference,
                  static_cast<unsigned long long>(f.bytes), f.recommended ? "  <- take" : "");
    s << line;
  }
  return s.str();
}

}  // namespace bsdfmix::bench
