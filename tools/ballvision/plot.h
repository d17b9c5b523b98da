#pragma once
// Line plots of `eval --plots` and `demo` (the paper's Fig. 4 and Fig. 5). Drawn by matplotlib
// through tools/python/plot_series.py, the plotting the project already ships for the main
// computer, instead of a hand-drawn plotter; without Python or matplotlib each plot becomes a
// text table beside where its PNG would be, and the outcome says why.
#include <cstdint>
#include <string>
#include <vector>

namespace bv::cli {

struct PlotSeries {
  std::string name;
  std::vector<double> x, y;  // a non-finite value breaks the line
  uint8_t r = 0, g = 0, b = 0;
  enum Style { kLine, kPoints, kDashed, kLinePoints } style = kLine;
};

struct Plot {
  std::string path;  // the PNG to write
  std::string title, xlabel, ylabel;
  std::vector<PlotSeries> series;
  double y_min = 0, y_max = 0;  // a fixed y range when y_max > y_min
};

struct PlotOutcome {
  bool ok = false;
  std::vector<std::string> written;  // the PNGs, or the text tables written instead
  std::string note;   // why tables were written instead of PNGs (empty when PNGs were)
  std::string error;  // when !ok: what failed; no target was replaced
};

/// Where the renderer is: $BV_PYTHON (default /usr/bin/python3, Debian's, which has matplotlib)
/// and $BV_PLOT_SCRIPT (default tools/python/plot_series.py of this source tree).
struct PlotRenderer {
  std::string python, script;
  static PlotRenderer FromEnvironment();
};

/// Writes every plot (one renderer process for all of them). A missing interpreter, script or
/// matplotlib gives tables (`<path minus .png>.txt`) and a note; a renderer that fails otherwise,
/// or a target that cannot be replaced, is an error. Files are replaced atomically.
PlotOutcome WritePlots(const std::vector<Plot>& plots,
                       const PlotRenderer& renderer = PlotRenderer::FromEnvironment());

/// The table written instead of `plot`'s PNG (also what a test compares against).
std::string PlotTable(const Plot& plot);

}  // namespace bv::cli
