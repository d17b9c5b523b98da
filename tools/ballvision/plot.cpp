#include "tools/ballvision/plot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/safe_write.h"

extern char** environ;

namespace bv::cli {
namespace {

namespace fs = std::filesystem;

constexpr int kNoMatplotlib = 3;  // plot_series.py's exit code when matplotlib is missing

const char* StyleName(PlotSeries::Style s) {
  switch (s) {
    case PlotSeries::kPoints:
      return "points";
    case PlotSeries::kDashed:
      return "dashed";
    case PlotSeries::kLinePoints:
      return "linepoints";
    case PlotSeries::kLine:
      break;
  }
  return "line";
}

std::string TablePath(const std::string& png) {
  fs::path p(png);
  return p.replace_extension(".txt").string();
}

std::string Spec(const std::vector<Plot>& plots) {
  nlohmann::json spec;
  spec["plots"] = nlohmann::json::array();
  for (size_t i = 0; i < plots.size(); ++i) {
    const Plot& p = plots[i];
    nlohmann::json j{{"file", std::to_string(i) + ".png"},
                     {"title", p.title},
                     {"xlabel", p.xlabel},
                     {"ylabel", p.ylabel}};
    if (p.y_max > p.y_min) j["ylim"] = {p.y_min, p.y_max};
    j["series"] = nlohmann::json::array();
    for (const auto& s : p.series) {
      char color[8];
      std::snprintf(color, sizeof color, "#%02x%02x%02x", s.r, s.g, s.b);
      // nlohmann writes a non-finite number as null, which breaks the line.
      j["series"].push_back({{"name", s.name},
                             {"x", s.x},
                             {"y", s.y},
                             {"color", color},
                             {"style", StyleName(s.style)}});
    }
    spec["plots"].push_back(std::move(j));
  }
  return spec.dump();
}

std::string LastLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

// Runs the renderer with its output in `log`; the exit code, or -1 (with `why`) when it could not
// be started or was killed.
int RunRenderer(const PlotRenderer& r, const fs::path& spec, const fs::path& out_dir,
                const fs::path& log, std::string& why) {
  posix_spawn_file_actions_t io;
  posix_spawn_file_actions_init(&io);
  posix_spawn_file_actions_addopen(&io, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&io, 1, 2);
  std::string a0 = r.python, a1 = r.script, a2 = spec.string(), a3 = out_dir.string();
  char* argv[] = {a0.data(), a1.data(), a2.data(), a3.data(), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, r.python.c_str(), &io, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&io);
  if (rc != 0) {
    why = r.python + ": " + std::strerror(rc);
    return -1;
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      why = std::string("waiting for the plot renderer: ") + std::strerror(errno);
      return -1;
    }
  }
  if (!WIFEXITED(status)) {
    why = r.script + " was killed by signal " + std::to_string(WTERMSIG(status));
    return -1;
  }
  return WEXITSTATUS(status);
}

PlotOutcome WriteTables(const std::vector<Plot>& plots, std::string note) {
  PlotOutcome out;
  for (const auto& p : plots) {
    const std::string path = TablePath(p.path);
    if (!WriteFileAtomic(path, PlotTable(p), out.error)) return out;
    out.written.push_back(path);
  }
  out.ok = true;
  out.note = std::move(note);
  return out;
}

PlotOutcome MovePngs(const std::vector<Plot>& plots, const fs::path& dir) {
  PlotOutcome out;
  for (size_t i = 0; i < plots.size(); ++i) {
    std::vector<uint8_t> png;
    std::string unread;
    if (!ReadFileBytes((dir / (std::to_string(i) + ".png")).string(), png, unread) || png.empty()) {
      out.error = plots[i].path + ": the plot renderer wrote no image";
      return out;
    }
    if (!WriteFileAtomic(plots[i].path, png, out.error)) return out;
    out.written.push_back(plots[i].path);
  }
  out.ok = true;
  return out;
}

// A private directory for the spec, the renderer's images and its log; removed on destruction.
struct TempDir {
  fs::path path;
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "ballvision-plot.XXXXXX").string();
    if (mkdtemp(tmpl.data())) path = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
};

}  // namespace

PlotRenderer PlotRenderer::FromEnvironment() {
  PlotRenderer r;
  const char* py = std::getenv("BV_PYTHON");
  const char* script = std::getenv("BV_PLOT_SCRIPT");
  r.python = py && *py ? py : "/usr/bin/python3";
  r.script = script && *script ? script : BV_SOURCE_DIR "/tools/python/plot_series.py";
  return r;
}

std::string PlotTable(const Plot& plot) {
  std::ostringstream o;
  o << "# " << plot.title << "\n# x: " << plot.xlabel << ", y: " << plot.ylabel << "\n";
  for (const auto& s : plot.series) {
    o << "\n# " << s.name << " (" << StyleName(s.style) << ")\n";
    char row[64];
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      std::snprintf(row, sizeof row, "%.6g %.6g\n", s.x[i], s.y[i]);
      o << row;
    }
  }
  return o.str();
}

PlotOutcome WritePlots(const std::vector<Plot>& plots, const PlotRenderer& renderer) {
  PlotOutcome out;
  for (const auto& p : plots) {
    if (!CheckOutputPath(p.path, out.error) || !CheckOutputPath(TablePath(p.path), out.error)) {
      return out;
    }
  }
  if (!fs::exists(renderer.script)) {
    return WriteTables(plots, renderer.script + " not found: wrote text tables instead of PNGs");
  }
  TempDir tmp;
  if (tmp.path.empty()) {
    out.error = std::string("no temporary directory for the plots: ") + std::strerror(errno);
    return out;
  }
  const fs::path spec = tmp.path / "spec.json", log = tmp.path / "renderer.log";
  if (!WriteFileAtomic(spec.string(), Spec(plots), out.error)) return out;
  std::string why;
  const int rc = RunRenderer(renderer, spec, tmp.path, log, why);
  if (rc == kNoMatplotlib || (rc < 0 && !fs::exists(renderer.python))) {
    if (rc == kNoMatplotlib) why = LastLine(log);
    return WriteTables(plots, why + ": wrote text tables instead of PNGs");
  }
  if (rc != 0) {
    out.error =
        rc < 0 ? why
               : renderer.script + " failed (exit " + std::to_string(rc) + "): " + LastLine(log);
    return out;
  }
  return MovePngs(plots, tmp.path);
}

}  // namespace bv::cli
