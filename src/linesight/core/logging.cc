#include "linesight/core/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace linesight {

void SetupLogging(int verbosity) {
  auto logger = spdlog::stderr_color_mt("linesight");
  logger->set_pattern("[%H:%M:%S.%e %^%l%$] %v");
  logger->set_level(verbosity >= 2   ? spdlog::level::debug
                    : verbosity == 1 ? spdlog::level::info
                                     : spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

}  // namespace linesight
