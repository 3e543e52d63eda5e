// `bsdfmix run`: every stage the config names, in order.
#include "core/progress.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix {

void run_all(const Config& config, const std::string& device_selector, const EngineOptions& engine) {
  const std::string dev = device_for(config, device_selector);
  stage_table(config, dev);
  if (config.fit) stage_fit(config, dev, SweepOptions{SIZE_MAX, nullptr, engine});
  if (config.converge) stage_converge(config, dev, engine);
  if (config.charts) stage_charts(config, dev, engine);
  log_line("run " + config.file + ": done");
}

}  // namespace bsdfmix
