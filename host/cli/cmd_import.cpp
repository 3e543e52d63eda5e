// `bsdfmix import rgl FILE.bsdf`: tabulates a measured RGL BRDF.
#include <memory>

#include "cli/commands.hpp"
#include "core/progress.hpp"
#include "tables/rgl_import.hpp"

namespace bsdfmix::cli {

void add_import(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("import", "tabulate measured data into a table file");
  auto* rgl = sub->add_subcommand(
      "rgl", "a measured isotropic BRDF of the RGL material database (.bsdf): luminance in `values`, "
             "RGB beside it, hemisphere domain, azimuthal symmetry");
  struct Args {  // the options, kept alive by the callback
    RglImportOptions opt;
    std::string output;
    std::string negative = "keep";
  };
  const auto args = std::make_shared<Args>();
  rgl->add_option("file", args->opt.file, "the RGL .bsdf file")->required()->check(existing_file());
  add_grid_options(*rgl, "[0, pi/2]", args->opt.n_theta_o, args->opt.n_theta_i, args->opt.n_phi_i);
  rgl->add_flag("--resolve", args->opt.resolve,
                "raise the three resolutions until the file's narrowest lobe spans 3 cells (docs/rgl.md, \"Resolving "
                "sharp lobes\"); the resolutions given are the least");
  rgl->add_option("--threads", args->opt.threads, "worker threads (0: all cores)")->capture_default_str();
  rgl->add_option("--negative", args->negative,
                  "negative RGB channels (out of the sRGB gamut): keep them signed, or clip each to 0 as Mitsuba "
                  "and pbrt render the file (docs/rgl.md)")
      ->capture_default_str()->check(CLI::IsMember({"keep", "clip"}));
  rgl->add_option("-o,--output", args->output, "the table file to write (HDF5)")->required();
  add_common_options(*rgl, common);
  sub->require_subcommand(1);
  rgl->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    parse_rgl_negative(args->negative, args->opt.negative);
    import_rgl_table(args->opt, args->output);
    log_line("wrote " + args->output);
  });
}

}  // namespace bsdfmix::cli
