#pragma once
// Sub-commands of the `ballvision` CLI. Each returns the process exit code: 0 success,
// 1 the job failed (message on stderr), 2 usage error.
namespace bv::cli {

int CmdDemo(int argc, char** argv);        // cmd_run.cpp
int CmdRun(int argc, char** argv);         // cmd_run.cpp
int CmdEval(int argc, char** argv);        // cmd_run.cpp
int CmdLut(int argc, char** argv);         // cmd_lut.cpp
int CmdCalibrate(int argc, char** argv);   // cmd_calibrate.cpp
int CmdCalib(int argc, char** argv);       // cmd_calib.cpp: convert JSON <-> blob, show
int CmdListen(int argc, char** argv);      // cmd_listen.cpp
int CmdSeq(int argc, char** argv);         // cmd_seq.cpp: inspect / convert captured sequences
int CmdEvalField(int argc, char** argv);   // cmd_field.cpp: pose, lines, obstacles vs truth
int CmdCapture(int argc, char** argv);     // cmd_capture.cpp: frames over the link
int CmdReadback(int argc, char** argv);    // cmd_readback.cpp: blob in use over the link
int CmdSync(int argc, char** argv);        // cmd_sync.cpp: clock sync with the coprocessor
int CmdDetect(int argc, char** argv);      // cmd_detect.cpp: the front end on still images
int CmdDetectEval(int argc, char** argv);  // cmd_detect.cpp: real-image figures

}  // namespace bv::cli
