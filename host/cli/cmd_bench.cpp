// `bsdfmix bench em`: the EM throughput benchmark (bench/em_bench.*, bench/README.md);
// `bsdfmix bench sampling`: a material's samplers against each other (bench/sampling_peers.*).
#include <cstdio>
#include <memory>
#include <string>

#include "bench/em_bench.hpp"
#include "bench/sampling_peers.hpp"
#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "fit/em.hpp"

namespace bsdfmix::cli {

namespace {

// --uniform-fraction as a number (earned is handled before).
double parse_share(const std::string& text) {
  std::size_t used = 0;
  double v = -1;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size()) throw ConfigError("bench sampling: --uniform-fraction '" + text + "' is not a number or earned");
  return v;
}

}  // namespace

void add_bench(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("bench", "benchmarks");
  auto* em = sub->add_subcommand("em", "EM throughput against the CPU reference and peer libraries");
  struct Args {  // the options, kept alive by the callback
    bench::EmBenchOptions o;
    bench::SamplingPeersOptions s;
    bool list_views = false, no_peers = false, no_reference = false, peers = false, reference = false;
    std::string share = "earned";  // --uniform-fraction: a number or earned
  };
  const auto args = std::make_shared<Args>();
  em->add_option("--k", args->o.k, "Gaussian components")->capture_default_str();
  em->add_option("--csv", args->o.csv, "CSV output file")->required();
  em->add_option("--iterations", args->o.iterations, "EM iterations timed")->capture_default_str();
  em->add_option("--slices", args->o.slices, "90 x 180 slices fitted by bsdfmix (peers and reference: 1)")
      ->capture_default_str();
  em->add_option("--repeat", args->o.repeat,
                 "rounds, each timing every row (bsdfmix, reference, each peer) and the FMA peak once; each row "
                 "keeps its fastest run")
      ->capture_default_str();
  em->add_option("--queues", args->o.queues, "work queues per device")->capture_default_str();
  em->add_option("--precision", args->o.precision, "accumulation: auto (fp64 where the device has it), fp32 or fp64")
      ->capture_default_str()->check(CLI::IsMember({"auto", "fp32", "fp64"}));
  em->add_option("--seed", args->o.seed, "data and initialization seed")->capture_default_str();
  em->add_flag("--no-peers", args->no_peers, "skip the peer programs of bench/peers (default: run them)");
  em->add_flag("--peers", args->peers, "run the peer programs (the default)");
  em->add_flag("--no-reference", args->no_reference, "skip the CPU reference (default: time it)");
  em->add_flag("--reference", args->reference, "time the CPU reference (the default)");
  add_common_options(*em, common);
  auto* sp = sub->add_subcommand(
      "sampling", "a material's samplers against each other (an RGL file's own sampler, the mixture, the table CDF, "
                  "uniform; under a scene also light sampling, MIS and the product)");
  sp->add_option("--rgl", args->s.rgl, "the RGL file (.bsdf): f everywhere, and its warps; default: f is the table")
      ->check(existing_file());
  // required but for --list-views: checked in bench_sampling, marked here
  sp->add_option("--mixture", args->s.mixture, "the mixture file fitted to the table (not needed with --list-views)")
      ->check(existing_file())->option_text("FILE REQUIRED");
  sp->add_option("--table", args->s.table,
                 "the table (imported from the RGL file, or a fiber table; not needed with --list-views)")
      ->check(existing_file())->option_text("FILE REQUIRED");
  sp->add_option("--csv", args->s.csv, "CSV output file (not needed with --list-views)")->option_text("TEXT REQUIRED");
  sp->add_option("--scene", args->s.scenes, "a scene file studied besides constant light (repeatable; default: none)")
      ->default_str("");
  sp->add_option("--light-cache", args->s.light_cache,
                 "where the scenes' lighting mixtures are cached (default: light_mixtures beside --csv)");
  sp->add_option("--directions", args->s.directions, "view elevations, uniform in [0, --theta-max]")->capture_default_str();
  sp->add_option("--theta-max", args->s.theta_max_deg, "largest view elevation (degrees)")->capture_default_str();
  sp->add_option("--samples", args->s.samples, "samples per sampler, view and lighting")->capture_default_str();
  sp->add_option("--seed", args->s.seed, "seed of the views and the samples")->capture_default_str();
  sp->add_option("--quadrature", args->s.quadrature, "the RGL integral's cells in sin^2 theta (x 2 in phi)")
      ->capture_default_str();
  sp->add_option("--uniform-fraction", args->share,
                 "the defensive mixture's uniform share: a number, or earned (each view's share from the mixture file)")
      ->capture_default_str();
  sp->add_option("--light-fraction", args->s.light_fraction, "light sampling's share in the mis_light_* samplers")
      ->capture_default_str();
  sp->add_flag("--list-views", args->list_views, "print the view elevations (radians, one a line) and exit");
  add_common_options(*sp, common);
  sp->callback([args, &common] {
    if (args->list_views) {
      const bench::SamplingPeersOptions& s = args->s;
      for (double t : bench::study_directions(s.directions, s.theta_max_deg * 3.14159265358979323846 / 180, s.seed))
        std::printf("%.9f\n", t);
      return;
    }
    if (common.quiet) Progress::set_enabled(false);
    bench::SamplingPeersOptions s = args->s;
    s.earned = args->share == "earned";
    if (!s.earned) s.uniform_fraction = parse_share(args->share);
    s.light_engine = run_environment().engine;
    bench::bench_sampling(s, common.device, common.quiet);
  });
  sub->require_subcommand(1);
  em->callback([args, &common] {
    if (common.quiet) Progress::set_enabled(false);
    bench::EmBenchOptions o = args->o;
    o.peers = !args->no_peers;
    o.reference = !args->no_reference;
    const EngineOptions engine = run_environment().engine;
    // BSDFMIX_PRECISION sets a precision left at auto
    if (parse_precision(o.precision) == EmPrecision::Auto) o.precision = precision_name(engine.precision);
    o.pool_log = engine.pool_log;
    bench::bench_em(o, common.device, common.quiet);
  });
}

}  // namespace bsdfmix::cli
