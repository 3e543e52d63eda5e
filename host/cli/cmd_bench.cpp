// `bsdfmix bench em`: the EM throughput benchmark (bench/em_bench.*, bench/README.md);
// `bsdfmix bench sampling`: a material's samplers against each other (bench/sampling_peers.*).
#include <cstdio>

#include "bench/em_bench.hpp"
#include "bench/sampling_peers.hpp"
#include "cli/commands.hpp"
#include "core/progress.hpp"

namespace bsdfmix::cli {

void add_bench(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("bench", "benchmarks");
  auto* em = sub->add_subcommand("em", "EM throughput against the CPU reference and peer libraries");
  static bench::EmBenchOptions o;
  em->add_option("--k", o.k, "Gaussian components")->capture_default_str();
  em->add_option("--csv", o.csv, "CSV output file")->required();
  em->add_option("--iterations", o.iterations, "EM iterations timed")->capture_default_str();
  em->add_option("--slices", o.slices, "90 x 180 slices fitted by bsdfmix (peers and reference: 1)")
      ->capture_default_str();
  em->add_option("--repeat", o.repeat,
                 "rounds, each timing every row (bsdfmix, reference, each peer) and the FMA peak once; each row "
                 "keeps its fastest run")
      ->capture_default_str();
  em->add_option("--queues", o.queues, "work queues per device")->capture_default_str();
  em->add_option("--precision", o.precision, "auto, fp32 or fp64 accumulation")->capture_default_str();
  em->add_option("--seed", o.seed, "data and initialization seed")->capture_default_str();
  em->add_flag("--peers,!--no-peers", o.peers, "run the peer programs of bench/peers (default: on)");
  em->add_flag("--reference,!--no-reference", o.reference, "time the CPU reference (default: on)");
  add_common_options(*em, common);
  auto* sp = sub->add_subcommand(
      "sampling", "a material's samplers against each other (an RGL file's own sampler, the mixture, the table CDF, "
                  "uniform; under a scene also light sampling, MIS and the product)");
  static bench::SamplingPeersOptions s;
  static bool list_views = false;
  sp->add_option("--rgl", s.rgl, "the RGL file (.bsdf): f everywhere, and its warps; without it f is the table");
  sp->add_option("--mixture", s.mixture, "the mixture file fitted to the table");
  sp->add_option("--table", s.table, "the table (imported from the RGL file, or a fiber table)");
  sp->add_option("--csv", s.csv, "CSV output file");
  sp->add_option("--scene", s.scenes, "a scene file studied besides constant light (repeatable)");
  sp->add_option("--light-cache", s.light_cache,
                 "where the scenes' lighting mixtures are cached (default: light_mixtures beside --csv)");
  sp->add_option("--directions", s.directions, "view elevations, uniform in [0, --theta-max]")->capture_default_str();
  sp->add_option("--theta-max", s.theta_max_deg, "largest view elevation (degrees)")->capture_default_str();
  sp->add_option("--samples", s.samples, "samples per sampler, view and lighting")->capture_default_str();
  sp->add_option("--seed", s.seed, "seed of the views and the samples")->capture_default_str();
  sp->add_option("--quadrature", s.quadrature, "the RGL integral's cells in sin^2 theta (x 2 in phi)")
      ->capture_default_str();
  sp->add_option("--uniform-fraction", s.uniform_fraction, "the defensive mixture's uniform share")
      ->capture_default_str();
  sp->add_option("--light-fraction", s.light_fraction, "light sampling's share in the mis_light_* samplers")
      ->capture_default_str();
  sp->add_flag("--list-views", list_views, "print the view elevations (radians, one a line) and exit");
  add_common_options(*sp, common);
  sp->callback([&common] {
    if (list_views) {
      for (double t : bench::study_directions(s.directions, s.theta_max_deg * 3.14159265358979323846 / 180, s.seed))
        std::printf("%.9f\n", t);
      return;
    }
    if (common.quiet) Progress::set_enabled(false);
    bench::bench_sampling(s, common.device, common.quiet);
  });
  sub->require_subcommand(1);
  em->callback([&common] {
    if (common.quiet) Progress::set_enabled(false);
    bench::bench_em(o, common.device, common.quiet);
  });
}

}  // namespace bsdfmix::cli
