// The settings of the ranging chain that `--ranging key=value` changes (range, eval ranging, eval
// plates), as one declarative table: each key names its RangingPipelineOptions member, the values
// it accepts (those of the options' Check()) and what it means. The help text of `--ranging` is
// written from it; docs/algorithms/ranging.md explains each setting at length.
#pragma once

#include <string_view>
#include <vector>

#include "linesight/core/key_value.h"
#include "linesight/ranging/pipeline.h"

namespace linesight {

const OptionTable<RangingPipelineOptions>& RangingSettingsTable();

// Parses `entries` ("key=value", or several joined by ',') of `flag` and applies them to
// `options`; throws UsageError naming the flag and the setting (an unknown key: with the valid
// keys; a value of the wrong type or outside its range: with the values it accepts).
void ApplyRangingSettings(std::string_view flag, const std::vector<std::string>& entries,
                          RangingPipelineOptions* options);

// What a report records of the chain it ran: {method, matcher (its settings), ranging_settings
// (every key of the table), disparity_range [min, max]}.
nlohmann::json RangingChainSettings(const RangingPipeline& pipeline);

}  // namespace linesight
