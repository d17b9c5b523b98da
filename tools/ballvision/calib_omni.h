#pragma once
// The paper's model-free omni calibration (section III-B) from a carpet sequence.
namespace bv::cli {

/// `calibrate omni SEQ --carpet SEQ/carpet.json --viewpoint-z F_O --out CALIB [--report DIR]`.
int CalibrateOmni(int argc, char** argv);

}  // namespace bv::cli
