// The stages of `bsdfmix run`, in order: table source -> fit sweep -> convergence -> charts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "config/config.hpp"
#include "fit/em.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {

// Makes the config's table with its generate or import section when the table is
// missing (or `force` is set); does nothing otherwise.
void stage_table(const Config& config, const std::string& device_selector);

// The fitting sweep of the `fit` section (options: sweep/sweep.hpp SweepOptions).
void stage_fit(const Config& config, const std::string& device_selector, const SweepOptions& options = {});

// The convergence study of the `converge` section; its lighting fits' engines run as
// `engine` says.
void stage_converge(const Config& config, const std::string& device_selector, const EngineOptions& engine = {});

// The charts of the stages that ran (matplotlib through /usr/bin/python3); the fit
// charts time fits with an engine run as `engine` says.
void stage_charts(const Config& config, const std::string& device_selector, const EngineOptions& engine = {});

// Every stage the config names, in order; the fits' engines run as `engine` says.
void run_all(const Config& config, const std::string& device_selector, const EngineOptions& engine = {});

}  // namespace bsdfmix
