// The plots of `eval --plots` and `demo`: drawn by matplotlib through plot_series.py, text
// tables when Python or matplotlib is missing, an error (nothing replaced) when drawing fails.
#include "tools/ballvision/plot.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

namespace bv::cli {
namespace {

namespace fs = std::filesystem;

class PlotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("plot_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  Plot Sample(const std::string& name) const {
    PlotSeries a{"height", {0, 1, 2, 3}, {0.5, 1.5, NAN, 0.25}, 200, 30, 30};
    PlotSeries b{"vz", {0, 1, 2}, {2, -1, -3}, 30, 60, 220};
    b.style = PlotSeries::kDashed;
    return {(dir_ / name).string(), "A title", "time [s]", "z [m]", {a, b}};
  }
  std::string Script(const std::string& body) const {
    const fs::path p = dir_ / "renderer.py";
    std::ofstream(p) << body;
    return p.string();
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  fs::path dir_;
};

TEST_F(PlotTest, MatplotlibDrawsEveryPlotAsAPng) {
  const PlotRenderer r = PlotRenderer::FromEnvironment();
  if (!fs::exists(r.python)) GTEST_SKIP() << r.python << " not installed";
  const PlotOutcome o = WritePlots({Sample("a.png"), Sample("b.png")}, r);
  ASSERT_TRUE(o.ok) << o.error;
  ASSERT_TRUE(o.note.empty()) << o.note;  // tools/dev.sh installs python3-matplotlib
  ASSERT_EQ(o.written.size(), 2u);
  for (const auto& f : o.written) {
    const cv::Mat img = cv::imread(f);
    ASSERT_FALSE(img.empty()) << f;
    EXPECT_EQ(img.cols, 900);
    EXPECT_EQ(img.rows, 560);
  }
  // Nothing of the renderer's is left beside the plots.
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir_)) files += e.is_regular_file();
  EXPECT_EQ(files, 2);
}

TEST_F(PlotTest, WithoutMatplotlibEachPlotIsATableAndTheNoteSaysWhy) {
  PlotRenderer r = PlotRenderer::FromEnvironment();
  if (!fs::exists(r.python)) GTEST_SKIP() << r.python << " not installed";
  r.script = Script(
      "import sys\nprint('matplotlib not available (No module named matplotlib)', "
      "file=sys.stderr)\nsys.exit(3)\n");
  const Plot p = Sample("fig.png");
  const PlotOutcome o = WritePlots({p}, r);
  ASSERT_TRUE(o.ok) << o.error;
  EXPECT_NE(o.note.find("matplotlib not available"), std::string::npos) << o.note;
  ASSERT_EQ(o.written, std::vector<std::string>{(dir_ / "fig.txt").string()});
  EXPECT_FALSE(fs::exists(dir_ / "fig.png"));
  const std::string table = Read(o.written[0]);
  EXPECT_EQ(table, PlotTable(p));
  EXPECT_EQ(table,
            "# A title\n# x: time [s], y: z [m]\n\n# height (line)\n0 0.5\n1 1.5\n2 nan\n3 0.25\n"
            "\n# vz (dashed)\n0 2\n1 -1\n2 -3\n");
}

TEST_F(PlotTest, AMissingInterpreterOrScriptGivesTables) {
  PlotRenderer r = PlotRenderer::FromEnvironment();
  r.python = (dir_ / "no-python").string();
  PlotOutcome o = WritePlots({Sample("p.png")}, r);
  ASSERT_TRUE(o.ok) << o.error;
  EXPECT_NE(o.note.find("no-python"), std::string::npos) << o.note;
  EXPECT_TRUE(fs::exists(dir_ / "p.txt"));

  r = PlotRenderer::FromEnvironment();
  r.script = (dir_ / "missing.py").string();
  o = WritePlots({Sample("q.png")}, r);
  ASSERT_TRUE(o.ok) << o.error;
  EXPECT_NE(o.note.find("missing.py not found"), std::string::npos) << o.note;
  EXPECT_TRUE(fs::exists(dir_ / "q.txt"));
}

TEST_F(PlotTest, ARendererThatFailsIsAnErrorAndReplacesNothing) {
  PlotRenderer r = PlotRenderer::FromEnvironment();
  if (!fs::exists(r.python)) GTEST_SKIP() << r.python << " not installed";
  std::ofstream(dir_ / "old.png") << "old";
  r.script =
      Script("import sys\nprint('spec.json: KeyError: plots', file=sys.stderr)\nsys.exit(2)\n");
  const PlotOutcome o = WritePlots({Sample("old.png")}, r);
  EXPECT_FALSE(o.ok);
  EXPECT_NE(o.error.find("failed (exit 2): spec.json: KeyError: plots"), std::string::npos)
      << o.error;
  EXPECT_EQ(Read((dir_ / "old.png").string()), "old");
  EXPECT_FALSE(fs::exists(dir_ / "old.txt"));
}

TEST_F(PlotTest, ATargetThatIsNotARegularFileIsRefusedBeforeAnythingIsDrawn) {
  fs::create_directories(dir_ / "second.png");
  const PlotOutcome o = WritePlots({Sample("first.png"), Sample("second.png")});
  EXPECT_FALSE(o.ok);
  EXPECT_NE(o.error.find("second.png"), std::string::npos) << o.error;
  EXPECT_NE(o.error.find("directory"), std::string::npos) << o.error;
  EXPECT_FALSE(fs::exists(dir_ / "first.png"));
}

}  // namespace
}  // namespace bv::cli
