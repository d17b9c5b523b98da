// ballvision listen: the main computer's side of the serial link. Reads a serial device, a pty,
// a file, stdin or a TCP socket (QEMU's -chardev socket), decodes with core/protocol, shows a
// live table and writes CSV.
#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <string>

#include "core/protocol/protocol.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/link_io.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"
#include "tools/ballvision/states_csv.h"

namespace bv::cli {
namespace {

constexpr char kListenUsage[] =
    "usage: ballvision listen SOURCE [--csv STATES.csv] [--status-csv STATUS.csv]\n"
    "                         [--pose-csv POSE.csv] [--lines-csv LINES.csv]\n"
    "                         [--obstacles-csv OBSTACLES.csv] [--goals-csv GOALS.csv]\n"
    "                         [--baud N] [--seconds S] [--quiet]\n"
    "  SOURCE: a serial device or pty (/dev/ttyUSB0), a file of captured bytes, '-'\n"
    "          for stdin, or tcp:HOST:PORT (e.g. QEMU -chardev socket)\n"
    "  Prints a live table (unless --quiet) and a summary; exit 1 if nothing valid\n"
    "  was received. --lines-csv / --obstacles-csv / --goals-csv: one row per point /\n"
    "  obstacle / goal (robot frame, m, rad), with the packet's seq, t_us and found count.\n";

// Every open file is committed even if one fails: what was received is kept where possible.
bool CommitAll(std::initializer_list<SafeOutput*> outs) {
  bool ok = true;
  for (SafeOutput* out : outs) {
    std::string e;
    if (out->is_open() && !out->Commit(e)) {
      std::fprintf(stderr, "ballvision listen: %s\n", e.c_str());
      ok = false;
    }
  }
  return ok;
}

struct ListenArgs {
  std::string source, csv, status, pose, lines, obstacles, goals;
  long baud = 921600;
  double seconds = 0;
  bool quiet = false;
};

// Returns -1 to go on, else the exit code.
int ParseListenArgs(int argc, char** argv, ListenArgs& a) {
  ArgParser p("ballvision listen", kListenUsage);
  p.Positional("SOURCE", a.source)
      .Text("--csv", a.csv)
      .Text("--status-csv", a.status)
      .Text("--pose-csv", a.pose)
      .Text("--lines-csv", a.lines)
      .Text("--obstacles-csv", a.obstacles)
      .Text("--goals-csv", a.goals)
      .Custom("--baud",
              [&a](const std::string& v, std::string& error) {
                if (!ArgIntAs("--baud", v, 1, 4000000, a.baud, error)) return false;
                if (BaudSupported(a.baud)) return true;
                error = "--baud: unsupported rate " + std::to_string(a.baud);
                return false;
              })
      .Number("--seconds", 0, 1e9, a.seconds)
      .Flag("--quiet", a.quiet);
  return p.Parse(argc, argv);
}

int Fail(const std::string& err) {
  std::fprintf(stderr, "ballvision listen: %s\n", err.c_str());
  return 1;
}

// Ball-state and status packets: counted, optionally written as CSV, shown (ball states every
// 10th).
struct StateStreams {
  SafeOutput csv, status_csv;
  uint32_t balls = 0, statuses = 0;
  uint16_t last_checks = 0;  // both cameras' check bytes in the last ball state
  bool quiet = false;

  bool Open(const std::string& csv_path, const std::string& status_path, std::string& err) {
    return (csv_path.empty() || csv.Open(csv_path, err)) &&
           (status_path.empty() || status_csv.Open(status_path, err));
  }

  void WriteHeaders() {
    if (csv.is_open()) csv << StatesCsvHeader(true);
    if (status_csv.is_open()) {
      status_csv << "seq,uptime_us,frames_processed,frame_rate_hz,frames_dropped,deadline_overruns,"
                    "packets_dropped,pairs_omni_missing,pairs_persp_missing,pairs_out_of_sync,"
                    "pairs_out_of_order,pairs_torn,calibration_id,lut_id,calibration_state,"
                    "lut_state,rx_errors,command_errors,pipeline_errors,last_proc_us,max_proc_us,"
                    "fault_flags,rx_overruns,rx_ring_full,rx_line_errors,feature_packets_dropped,"
                    "line_points_unsent,check_omni,check_persp,omni_faults,persp_faults,"
                    "pairs_omni_unusable,pairs_persp_unusable,change_omni_deg,change_persp_deg,"
                    "confidence_omni,confidence_persp\n";
    }
  }

  bool Commit() { return CommitAll({&csv, &status_csv}); }

  // False if the payload does not parse.
  bool Ball(const protocol::FrameView& f) {
    BallState s;
    if (!protocol::ParseBallState(f.payload, s).ok()) return false;
    ++balls;
    if (csv.is_open()) csv << StatesCsvRow(f.seq, s, true);
    if (!quiet && balls % 10 == 1) {
      std::printf(
          "ball  seq %6u t %10.3f s  %-5s  x %7.3f y %7.3f z %6.3f  v %6.2f %6.2f "
          "%6.2f  %-8s gap %.3f\n",
          f.seq, s.t_us * 1e-6, s.found ? "found" : "-", s.x_m, s.y_m, s.z_m, s.vx_mps, s.vy_mps,
          s.vz_mps, BallModeName(s.mode), s.ray_gap_m);
    }
    // A camera's state change is shown at once, not with every tenth ball state.
    const uint16_t checks = static_cast<uint16_t>(s.omni_check.Byte() << 8 | s.persp_check.Byte());
    if (!quiet && checks != last_checks) {
      std::printf("cameras seq %6u: omni %s, persp %s\n", f.seq,
                  CameraCheckText(s.omni_check).c_str(), CameraCheckText(s.persp_check).c_str());
    }
    last_checks = checks;
    return true;
  }

  bool Status(const protocol::FrameView& f) {
    protocol::StatusReport st;
    if (!protocol::ParseStatus(f.payload, st).ok()) return false;
    ++statuses;
    if (status_csv.is_open()) {
      status_csv << f.seq << ',' << st.uptime_us << ',' << st.frames_processed << ','
                 << st.frame_rate_mhz / 1000.0 << ',' << st.frames_dropped << ','
                 << st.deadline_overruns << ',' << st.packets_dropped << ','
                 << st.pairs_omni_missing << ',' << st.pairs_persp_missing << ','
                 << st.pairs_out_of_sync << ',' << st.pairs_out_of_order << ',' << st.pairs_torn
                 << ',' << st.calibration_id << ',' << st.lut_id << ',' << int(st.calibration_state)
                 << ',' << int(st.lut_state) << ',' << st.rx_errors << ',' << st.command_errors
                 << ',' << st.pipeline_errors << ',' << st.last_proc_us << ',' << st.max_proc_us
                 << ',' << st.fault_flags << ',' << st.rx_overruns << ',' << st.rx_ring_full << ','
                 << st.rx_line_errors << ',' << st.feature_packets_dropped << ','
                 << st.line_points_unsent << ',' << (st.check_omni & 3) << ','
                 << (st.check_persp & 3) << ',' << (st.check_omni >> 2) << ','
                 << (st.check_persp >> 2) << ',' << st.pairs_omni_unusable << ','
                 << st.pairs_persp_unusable << ',' << st.change_omni_cdeg / 100.0 << ','
                 << st.change_persp_cdeg / 100.0 << ',' << st.confidence_omni_pct / 100.0 << ','
                 << st.confidence_persp_pct / 100.0 << '\n';
    }
    if (!quiet) {
      std::printf(
          "status seq %5u up %8.3f s  frames %6u  %.1f Hz  dropped %u  overruns %u  "
          "pkts dropped %u  calib %s lut %s  proc %u us (max %u)  rx lost: overrun "
          "%u ring-full %u line %u\n"
          "       cameras: omni %s (%.2f deg), persp %s (%.2f deg)  (unusable pairs %u / %u)\n",
          f.seq, st.uptime_us * 1e-6, st.frames_processed, st.frame_rate_mhz / 1000.0,
          st.frames_dropped, st.deadline_overruns, st.packets_dropped,
          st.calibration_state == 0 ? "ok" : "MISSING/CORRUPT",
          st.lut_state == 0 ? "ok" : "MISSING/CORRUPT", st.last_proc_us, st.max_proc_us,
          st.rx_overruns, st.rx_ring_full, st.rx_line_errors,
          CameraCheckText(st.check_omni).c_str(), st.change_omni_cdeg / 100.0,
          CameraCheckText(st.check_persp).c_str(), st.change_persp_cdeg / 100.0,
          st.pairs_omni_unusable, st.pairs_persp_unusable);
    }
    return true;
  }
};

// Pose, line-point, obstacle and goal packets: counted, optionally written as CSV, shown every
// 10th.
struct FieldStreams {
  SafeOutput pose, lines, obstacles, goals;
  uint32_t poses = 0, line_packets = 0, obstacle_packets = 0, goal_packets = 0;
  bool quiet = false;

  bool Open(const std::string& pose_path, const std::string& lines_path,
            const std::string& obstacles_path, const std::string& goals_path, std::string& err) {
    if (!pose_path.empty()) {
      if (!pose.Open(pose_path, err)) return false;
      pose << "seq,t_us,state,x,y,heading,sigma_x,sigma_y,sigma_heading,quality,ambiguous,"
              "hint_rejected,usable,points_used,inliers\n";
    }
    if (!lines_path.empty()) {
      if (!lines.Open(lines_path, err)) return false;
      lines << "seq,t_us,found,index,x,y\n";
    }
    if (!obstacles_path.empty()) {
      if (!obstacles.Open(obstacles_path, err)) return false;
      obstacles << "seq,t_us,found,index,x,y,radius\n";
    }
    if (!goals_path.empty()) {
      if (!goals.Open(goals_path, err)) return false;
      goals << "seq,t_us,found,index,x,y,bearing,half_width,rays,post_rays,which,which_ambiguous\n";
    }
    return true;
  }

  bool Commit() { return CommitAll({&pose, &lines, &obstacles, &goals}); }

  // False if the payload does not parse.
  bool Pose(const protocol::FrameView& f) {
    protocol::PoseReport p;
    if (!protocol::ParsePose(f.payload, p).ok()) return false;
    ++poses;
    if (pose.is_open()) {
      pose << f.seq << ',' << p.t_us << ',' << int(p.state) << ',' << p.x_m << ',' << p.y_m << ','
           << p.heading_rad << ',' << p.sigma_x_m << ',' << p.sigma_y_m << ','
           << p.sigma_heading_rad << ',' << p.quality << ',' << int(p.ambiguous) << ','
           << int(p.hint_rejected) << ',' << int(p.usable) << ',' << p.points_used << ','
           << p.inliers << '\n';
    }
    if (!quiet && poses % 10 == 1) {
      std::printf(
          "pose  seq %6u t %10.3f s  state %u%s  x %7.3f y %7.3f h %6.3f  sigma %.3f %.3f "
          "%.3f  q %.2f  %u/%u inliers%s\n",
          f.seq, p.t_us * 1e-6, p.state, p.usable ? " usable" : "", p.x_m, p.y_m, p.heading_rad,
          p.sigma_x_m, p.sigma_y_m, p.sigma_heading_rad, p.quality, p.inliers, p.points_used,
          p.ambiguous ? "  AMBIGUOUS" : "");
    }
    return true;
  }

  bool Lines(const protocol::FrameView& f) {
    protocol::LinePointsReport r;
    if (!protocol::ParseLinePoints(f.payload, r).ok()) return false;
    ++line_packets;
    for (int i = 0; lines.is_open() && i < r.count; ++i) {
      lines << f.seq << ',' << r.t_us << ',' << r.found << ',' << i << ','
            << r.points[i].x_mm * 1e-3 << ',' << r.points[i].y_mm * 1e-3 << '\n';
    }
    if (!quiet && line_packets % 10 == 1) {
      std::printf("lines seq %6u t %10.3f s  %u of %u points\n", f.seq, r.t_us * 1e-6, r.count,
                  r.found);
    }
    return true;
  }

  bool Obstacles(const protocol::FrameView& f) {
    protocol::ObstaclesReport r;
    if (!protocol::ParseObstacles(f.payload, r).ok()) return false;
    ++obstacle_packets;
    for (int i = 0; obstacles.is_open() && i < r.count; ++i) {
      const protocol::ObstacleMm& o = r.obstacles[i];
      obstacles << f.seq << ',' << r.t_us << ',' << int(r.found) << ',' << i << ',' << o.x_mm * 1e-3
                << ',' << o.y_mm * 1e-3 << ',' << o.radius_mm * 1e-3 << '\n';
    }
    if (!quiet && obstacle_packets % 10 == 1) {
      std::printf("obst  seq %6u t %10.3f s  %u obstacles", f.seq, r.t_us * 1e-6, r.count);
      for (int i = 0; i < r.count && i < 4; ++i) {
        std::printf("  (%.2f, %.2f r %.2f)", r.obstacles[i].x_mm * 1e-3, r.obstacles[i].y_mm * 1e-3,
                    r.obstacles[i].radius_mm * 1e-3);
      }
      std::printf("\n");
    }
    return true;
  }

  bool Goals(const protocol::FrameView& f) {
    protocol::GoalsReport r;
    if (!protocol::ParseGoals(f.payload, r).ok()) return false;
    ++goal_packets;
    for (int i = 0; goals.is_open() && i < r.count; ++i) {
      const protocol::GoalMm& g = r.goals[i];
      goals << f.seq << ',' << r.t_us << ',' << int(r.found) << ',' << i << ',' << g.x_mm * 1e-3
            << ',' << g.y_mm * 1e-3 << ',' << g.bearing_mrad * 1e-3 << ','
            << g.half_width_mrad * 1e-3 << ',' << int(g.rays) << ',' << int(g.post_rays) << ','
            << int(g.which) << ',' << int(g.which_ambiguous) << '\n';
    }
    if (!quiet && r.count > 0 && goal_packets % 10 == 1) {
      std::printf("goals seq %6u t %10.3f s  %u goals", f.seq, r.t_us * 1e-6, r.count);
      for (int i = 0; i < r.count; ++i) {
        std::printf("  (%.2f, %.2f which %d)", r.goals[i].x_mm * 1e-3, r.goals[i].y_mm * 1e-3,
                    r.goals[i].which);
      }
      std::printf("\n");
    }
    return true;
  }
};

// The frames of one link: sequence gaps and bad payloads counted, each kind to its stream.
struct Listener {
  StateStreams states;
  FieldStreams field;
  protocol::Decoder decoder;
  protocol::FrameView frame;
  uint32_t others = 0, bad_payloads = 0, seq_gaps = 0;
  bool have_seq = false;
  uint32_t last_seq = 0;

  void Feed(const uint8_t* bytes, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      if (decoder.Push(bytes[i], frame)) Dispatch();
    }
  }

  void Dispatch() {
    if (have_seq && frame.seq != last_seq + 1) ++seq_gaps;
    have_seq = true;
    last_seq = frame.seq;
    bool parsed = true;
    if (frame.type == protocol::MsgType::kBallState) {
      parsed = states.Ball(frame);
    } else if (frame.type == protocol::MsgType::kStatus) {
      parsed = states.Status(frame);
    } else if (frame.type == protocol::MsgType::kPose) {
      parsed = field.Pose(frame);
    } else if (frame.type == protocol::MsgType::kLinePoints) {
      parsed = field.Lines(frame);
    } else if (frame.type == protocol::MsgType::kObstacles) {
      parsed = field.Obstacles(frame);
    } else if (frame.type == protocol::MsgType::kGoals) {
      parsed = field.Goals(frame);
    } else {
      ++others;
    }
    if (!parsed) ++bad_payloads;
  }

  void PrintSummary() const {
    const auto& ds = decoder.stats();
    std::printf(
        "summary: ball_states=%u status=%u other=%u bad_payloads=%u seq_gaps=%u "
        "decoder_errors=%u (crc %u, cobs %u, oversize %u, short %u, version %u, length %u) "
        "pose=%u lines=%u obstacles=%u goals=%u\n",
        states.balls, states.statuses, others, bad_payloads, seq_gaps, ds.errors(), ds.crc_errors,
        ds.cobs_errors, ds.oversize, ds.short_frames, ds.version_errors, ds.length_errors,
        field.poses, field.line_packets, field.obstacle_packets, field.goal_packets);
  }
};

// Reads until the source ends, `seconds` pass or a signal arrives.
void ReadLink(int fd, double seconds, Listener& l) {
  const auto start = std::chrono::steady_clock::now();
  uint8_t buf[4096];
  for (;;) {
    const ssize_t n = ReadLinkChunk(fd, buf, sizeof buf, start, seconds, "ballvision listen");
    if (n < 0) break;
    if (n > 0) l.Feed(buf, static_cast<size_t>(n));
  }
}

}  // namespace

int CmdListen(int argc, char** argv) {
  ListenArgs a;
  if (const int rc = ParseListenArgs(argc, argv, a); rc >= 0) return rc;
  std::string err;
  bool writable = false;  // listen only reads
  const int fd = OpenLink(a.source, a.baud, writable, err, /*read_only=*/true);
  if (fd < 0) return Fail(err);
  Listener l;
  if (!l.states.Open(a.csv, a.status, err)) return Fail(err);
  InstallInterruptHandlers();
  l.states.WriteHeaders();
  l.states.quiet = l.field.quiet = a.quiet;
  if (!l.field.Open(a.pose, a.lines, a.obstacles, a.goals, err)) return Fail(err);
  ReadLink(fd, a.seconds, l);
  if (fd != STDIN_FILENO) close(fd);
  if (InterruptSignal()) ReportInterrupt("ballvision listen");
  const bool field_written = l.field.Commit();
  const bool written = l.states.Commit() && field_written;
  l.PrintSummary();
  if (InterruptSignal()) return InterruptExitCode();
  return written && (l.states.balls + l.states.statuses) > 0 ? 0 : 1;
}

}  // namespace bv::cli
