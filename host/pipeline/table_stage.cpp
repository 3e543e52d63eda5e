// The table stage: generate or import the config's table when it is missing.
#include <filesystem>

#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "tables/fiber_generator.hpp"
#include "tables/rgl_import.hpp"

namespace bsdfmix {

namespace {

// A section's table grid (generate or import) into its tabulator's options.
template <class Options, class Section>
void set_grid(Options& opt, const Section& s) {
  opt.n_theta_o = std::size_t(s.theta_o);
  opt.n_theta_i = std::size_t(s.theta_i);
  opt.n_phi_i = std::size_t(s.phi_i);
}

}  // namespace

void stage_table(const Config& config, const std::string& device_selector) {
  const bool present = std::filesystem::exists(config.table);
  if (config.generate && (!present || config.generate->force)) {
    const GenerateSection& g = *config.generate;
    FiberGenerateOptions opt;
    opt.preset = g.preset;
    set_grid(opt, g);
    opt.symmetry = g.symmetry;
    opt.n_phi_o = g.symmetry ? 0 : std::size_t(g.phi_o);
    opt.noise = g.noise;
    opt.seed = g.seed;
    validate_fiber_options(opt);
    generate_fiber_table(opt, device_selector, config.table);
  } else if (config.import && (!present || config.import->force)) {
    const ImportSection& s = *config.import;
    RglImportOptions opt;
    opt.file = s.rgl;
    set_grid(opt, s);
    opt.resolve = s.resolve;
    parse_rgl_negative(s.negative, opt.negative);
    import_rgl_table(opt, config.table);
  } else if (present) {
    log_line("table " + config.table + ": present");
  }
}

}  // namespace bsdfmix
