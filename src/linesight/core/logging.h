// Logging goes to stderr (stdout is reserved for reports and tables).
#pragma once

namespace linesight {

// verbosity: 0 = warnings and errors, 1 = info, 2 = debug.
void SetupLogging(int verbosity);

}  // namespace linesight
