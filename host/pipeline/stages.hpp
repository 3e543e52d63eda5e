// The stages of `bsdfmix run`, in order: table source -> fit sweep -> convergence -> charts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "config/config.hpp"

namespace bsdfmix {

// Makes the config's table with its generate or import section when the table is
// missing (or `force` is set); does nothing otherwise.
void stage_table(const Config& config, const std::string& device_selector);

// The fitting sweep of the `fit` section; with max_batches, stops after committing that
// many batches (a later run resumes).
void stage_fit(const Config& config, const std::string& device_selector, std::size_t max_batches = SIZE_MAX);

// The convergence study of the `converge` section.
void stage_converge(const Config& config, const std::string& device_selector);

// The charts of the stages that ran (matplotlib through /usr/bin/python3).
void stage_charts(const Config& config, const std::string& device_selector);

// Every stage the config names, in order.
void run_all(const Config& config, const std::string& device_selector);

}  // namespace bsdfmix
