// Every subcommand: int Run<Name>(int argc, char** argv), argv[0] being the subcommand name.
// Each lives in apps/commands/<name>.cc and is listed in the table in apps/linesight.cc.
#pragma once

namespace linesight::cli {

int RunDemo(int argc, char** argv);
int RunDisparity(int argc, char** argv);
int RunEval(int argc, char** argv);
int RunRectify(int argc, char** argv);
int RunCloud(int argc, char** argv);
int RunRange(int argc, char** argv);
int RunInspect(int argc, char** argv);
int RunEvalRanging(int argc, char** argv);  // `linesight eval ranging`, dispatched by eval.cc
int RunBench(int argc, char** argv);
int RunCalibrate(int argc, char** argv);
int RunPattern(int argc, char** argv);
int RunEvalCalibration(int argc,
                       char** argv);  // `linesight eval calibration`, dispatched by eval.cc
int RunRender(int argc, char** argv);
int RunEvalSweep(int argc, char** argv);      // `linesight eval sweep`, dispatched by eval.cc
int RunEvalReport(int argc, char** argv);     // `linesight eval report`, dispatched by eval.cc
int RunEvalObstacles(int argc, char** argv);  // `linesight eval obstacles`, dispatched by eval.cc
int RunEvalPlates(int argc, char** argv);     // `linesight eval plates`, dispatched by eval.cc
int RunEvalSequences(int argc, char** argv);  // `linesight eval sequences`, dispatched by eval.cc
int RunEvalFaults(int argc, char** argv);     // `linesight eval faults`, dispatched by eval.cc
int RunServe(int argc, char** argv);
int RunAcquire(int argc, char** argv);
int RunBatch(int argc, char** argv);

}  // namespace linesight::cli
