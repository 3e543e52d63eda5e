// `bsdfmix bench em`: the EM throughput benchmark (bench/em_bench.*, bench/README.md).
#include "bench/em_bench.hpp"
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
  sub->require_subcommand(1);
  em->callback([&common] {
    if (common.quiet) Progress::set_enabled(false);
    bench::bench_em(o, common.device, common.quiet);
  });
}

}  // namespace bsdfmix::cli
