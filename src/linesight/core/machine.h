// Facts about the machine and this process for benchmark reports.
#pragma once

#include <string>

namespace linesight {

// The CPU's model name from /proc/cpuinfo ("AMD EPYC ..."), or "unknown".
std::string CpuModel();

// A field of /proc/self/status in kB ("VmHWM", "VmRSS"), or -1.
long ProcStatusKb(const std::string& field);

// Minor page faults of this process so far (getrusage): first touches of fresh memory.
long MinorPageFaults();

}  // namespace linesight
