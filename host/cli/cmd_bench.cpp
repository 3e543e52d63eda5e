// `bsdfmix bench em`: the EM throughput benchmark (bench/em_bench.*, bench/README.md);
// `bsdfmix bench sampling`: an RGL file's samplers against each other (bench/sampling_peers.*).
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
  auto* sp = sub->add_subcommand("sampling", "an RGL file's own sampler against the mixture, the table CDF and uniform");
  static bench::SamplingPeersOptions s;
  sp->add_option("--rgl", s.rgl, "the RGL file (.bsdf): f everywhere, and its warps")->required();
  sp->add_option("--mixture", s.mixture, "the mixture file fitted to its table")->required();
  sp->add_option("--table", s.table, "the table imported from it")->required();
  sp->add_option("--csv", s.csv, "CSV output file")->required();
  sp->add_option("--directions", s.directions, "view elevations, uniform in [0, --theta-max]")->capture_default_str();
  sp->add_option("--theta-max", s.theta_max_deg, "largest view elevation (degrees)")->capture_default_str();
  sp->add_option("--samples", s.samples, "samples per sampler and view")->capture_default_str();
  sp->add_option("--seed", s.seed, "seed of the views and the samples")->capture_default_str();
  sp->add_option("--quadrature", s.quadrature, "the exact integral's cells in sin^2 theta (x 2 in phi)")
      ->capture_default_str();
  sp->add_option("--uniform-fraction", s.uniform_fraction, "the defensive mixture's uniform share")
      ->capture_default_str();
  add_common_options(*sp, common);
  sp->callback([&common] { bench::bench_sampling(s, common.quiet); });
  sub->require_subcommand(1);
  em->callback([&common] {
    if (common.quiet) Progress::set_enabled(false);
    bench::bench_em(o, common.device, common.quiet);
  });
}

}  // namespace bsdfmix::cli
