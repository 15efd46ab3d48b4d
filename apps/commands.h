// Every subcommand: int Run<Name>(int argc, char** argv), argv[0] being the subcommand name.
// Each lives in apps/commands/<name>.cc and is listed in the table in apps/linesight.cc.
#pragma once

namespace linesight::cli {

int RunDisparity(int argc, char** argv);
int RunEval(int argc, char** argv);

}  // namespace linesight::cli
