// The offline HTML view: page contents (nothing remote, data consistent,
// deterministic subsampling, errors) and a headless Chromium load that must
// render without any console error, failed load or blocked request.
#include "quadhand/viz/html_view.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/geometry/primitives.h"
#include "support/run_command.h"

namespace quadhand::viz {
namespace {

namespace fs = std::filesystem;

// A fresh folder under the system temporary folder, removed at the end.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "quadhand_viz_XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Points of a room: floor, a wall at x = -2 with a window, a table and a cup
// beyond it; about `target` points in all.
std::vector<Vec3> RoomCloud(int target) {
  const double floor_area = 7.0 * 4.0, wall_area = 4.0 * 2.5, table_area = 0.8 * 0.8;
  const double spacing = std::sqrt((floor_area + wall_area + 2 * table_area) / target);
  std::vector<Vec3> points;
  for (double x = -5.0; x <= 2.0; x += spacing) {
    for (double y = -2.0; y <= 2.0; y += spacing) points.emplace_back(x, y, 0.0);
  }
  for (double y = -2.0; y <= 2.0; y += spacing) {
    for (double z = 0.0; z <= 2.5; z += spacing) {
      const bool window = std::abs(y) < 0.55 && z > 0.85 && z < 1.75;
      if (!window) points.emplace_back(-2.0, y, z);
    }
  }
  for (double x = -3.6; x <= -2.8; x += spacing) {  // table top and its front
    for (double y = -0.4; y <= 0.4; y += spacing) points.emplace_back(x, y, 0.75);
    for (double z = 0.0; z <= 0.75; z += spacing) points.emplace_back(x, -0.4, z);
  }
  for (double a = 0.0; a < 2 * M_PI; a += spacing / 0.04) {  // cup
    for (double z = 0.75; z <= 0.85; z += spacing / 2) {
      points.emplace_back(-3.2 + 0.04 * std::cos(a), 0.04 * std::sin(a), z);
    }
  }
  return points;
}

Pose PoseOf(const Vec3& p, const Mat3& r) { return MakePose(p, r); }

// A quadrotor-like box with a three-link box arm flying through the window
// and reaching down into the cup.
HtmlViewData SyntheticScene(int num_points) {
  HtmlViewData data;
  data.title = "window_cup <synthetic> & test";
  data.summary = "success: true\nduration: 4.00 s\nmin clearance: 0.031 m";
  data.points = RoomCloud(num_points);
  const char* names[] = {"base_link", "link1", "link2", "tool"};
  const Vec3 sizes[] = {{0.50, 0.50, 0.10}, {0.05, 0.05, 0.30}, {0.04, 0.04, 0.25}, {0.02, 0.02, 0.10}};
  for (int j = 0; j < 4; ++j) {
    geometry::Box box;
    box.size = sizes[j];
    // Arm links hang from their joint (link origin at the top of the box).
    if (j > 0) box.pose.translation() = Vec3(0, 0, -sizes[j].z() / 2);
    data.links.push_back({names[j], geometry::TessellateBox(box)});
  }
  // Through the window at x = -2 with the arm folded, then over the table
  // with the arm unfolding straight down into the cup.
  const int n = 201;
  const double duration = 4.0;
  const Vec3 start(1.0, 0.4, 1.2), via(-1.6, 0.0, 1.25), goal(-3.2, 0.0, 1.55);
  for (int i = 0; i < n; ++i) {
    const double t = duration * i / (n - 1), s = t / duration;
    const Vec3 p = (1 - s) * (1 - s) * start + 2 * s * (1 - s) * via + s * s * goal;
    const Mat3 r_base = Eigen::AngleAxisd(M_PI - 0.4 * (1 - s), Vec3::UnitZ()).toRotationMatrix();
    const double unfold = s < 0.6 ? 0.0 : (s > 0.95 ? 1.0 : (s - 0.6) / 0.35);
    const double q1 = 0.5 * M_PI * (1 - unfold), q2 = -0.6 * M_PI * (1 - unfold), q3 = 0.5 * std::sin(2 * M_PI * s);
    const Pose base = PoseOf(p, r_base);
    const Pose link1 = base * PoseOf(Vec3(0, 0, -0.06), Eigen::AngleAxisd(q1, Vec3::UnitY()).toRotationMatrix());
    const Pose link2 = link1 * PoseOf(Vec3(0, 0, -0.30), Eigen::AngleAxisd(q2, Vec3::UnitY()).toRotationMatrix());
    const Pose tool = link2 * PoseOf(Vec3(0, 0, -0.25), Eigen::AngleAxisd(q3, Vec3::UnitZ()).toRotationMatrix());
    data.times.push_back(t);
    data.link_poses.push_back({base, link1, link2, tool});
    // A box beside the table slides along y and turns, as a moving target's points.
    data.moving_displacements.push_back(
        MakePose(Vec3(0.0, 0.1 * t, 0.0), Eigen::AngleAxisd(0.2 * t, Vec3::UnitZ()).toRotationMatrix()));
    data.base_path.push_back(p);
    data.tool_path.push_back(tool * Vec3(0, 0, -0.10));
  }
  for (double x = -3.0; x <= -2.9; x += 0.01) {
    for (double y = 0.5; y <= 0.6; y += 0.01) data.moving_points.emplace_back(x, y, 0.8);
  }
  data.has_insertion = true;
  data.insertion_end = data.tool_path.back();
  data.insertion_start = data.insertion_end + Vec3(0, 0, 0.10);
  return data;
}

std::string Attribute(const std::string& dom, const std::string& name) {
  std::smatch m;
  if (std::regex_search(dom, m, std::regex(name + "=\"([^\"]*)\""))) return m[1];
  return "";
}

// --- page contents --------------------------------------------------------------

TEST(HtmlViewTest, PageIsSelfContained) {
  auto html = RenderHtmlView(SyntheticScene(20000));
  ASSERT_TRUE(html.ok()) << html.status().message();
  // No URL of any remote resource anywhere (three.js travels as base64 data: URLs).
  EXPECT_EQ(html->find("http://"), std::string::npos);
  EXPECT_EQ(html->find("https://"), std::string::npos);
  EXPECT_EQ(html->find("//cdn"), std::string::npos);
  // No element or rule that loads something by reference.
  EXPECT_FALSE(std::regex_search(*html, std::regex("<script[^>]*\\ssrc\\s*=", std::regex::icase)));
  EXPECT_FALSE(std::regex_search(*html, std::regex("<link[^>]*href\\s*=\\s*\"(?!data:)", std::regex::icase)));
  EXPECT_FALSE(std::regex_search(*html, std::regex("<(img|iframe|embed|object|video|audio|source)\\b", std::regex::icase)));
  EXPECT_EQ(html->find("@import"), std::string::npos);
  EXPECT_EQ(html->find("url("), std::string::npos);
  EXPECT_EQ(html->find("fetch("), std::string::npos);
  EXPECT_EQ(html->find("XMLHttpRequest"), std::string::npos);
  // Modules resolve to inlined data only, and the page forbids anything else.
  EXPECT_NE(html->find("\"three\":\"data:text/javascript;base64,"), std::string::npos);
  EXPECT_NE(html->find("default-src 'none'"), std::string::npos);
  EXPECT_EQ(html->find("@@"), std::string::npos) << "a template placeholder was left";
  // The title is escaped in HTML and in the data block.
  EXPECT_NE(html->find("<title>window_cup &lt;synthetic&gt; &amp; test</title>"), std::string::npos);
  EXPECT_NE(html->find("\"title\":\"window_cup \\u003csynthetic\\u003e \\u0026 test\""), std::string::npos);
  EXPECT_STREQ(EmbeddedThreeVersion(), "0.170.0");
}

TEST(HtmlViewTest, SubsamplesLargeCloudsDeterministically) {
  HtmlViewData data = SyntheticScene(120000);
  const std::size_t total = data.points.size();
  data.points.push_back(Vec3(NAN, 0, 0));  // skipped, not an error
  HtmlViewOptions options;
  options.max_points = 50000;
  auto a = RenderHtmlView(data, options);
  auto b = RenderHtmlView(data, options);
  ASSERT_TRUE(a.ok()) << a.status().message();
  EXPECT_EQ(*a, *b);
  EXPECT_NE(a->find("\"points\":{\"count\":50000,\"total\":" + std::to_string(total) + ","), std::string::npos);

  auto full = RenderHtmlView(data);
  ASSERT_TRUE(full.ok());
  EXPECT_NE(full->find("\"points\":{\"count\":" + std::to_string(total) + ","), std::string::npos);
  // 12 bytes a point as base64 (16 characters), three.js about 0.95 MB.
  EXPECT_LT(full->size(), total * 16 + 1'300'000);
  std::cout << "page of " << total << " points: " << full->size() / 1024 << " KiB; capped at 50000: "
            << a->size() / 1024 << " KiB; empty scene: " << RenderHtmlView(HtmlViewData{})->size() / 1024
            << " KiB\n";
}

TEST(HtmlViewTest, RejectsInconsistentData) {
  const HtmlViewData good = SyntheticScene(1000);
  auto expect_invalid = [](const HtmlViewData& data, const char* what) {
    auto html = RenderHtmlView(data);
    ASSERT_FALSE(html.ok()) << what;
    EXPECT_EQ(html.status().code(), core::StatusCode::kInvalidArgument) << what;
  };
  HtmlViewData d = good;
  d.link_poses.pop_back();
  expect_invalid(d, "fewer pose rows than times");
  d = good;
  d.link_poses[3].pop_back();
  expect_invalid(d, "a row with a link missing");
  d = good;
  std::swap(d.times[4], d.times[5]);
  expect_invalid(d, "decreasing times");
  d = good;
  d.links[1].mesh_in_link_frame.triangles[0] = Eigen::Vector3i(0, 1, 99);
  expect_invalid(d, "triangle index out of range");
  d = good;
  d.link_poses[2][0].translation().x() = INFINITY;
  expect_invalid(d, "non-finite pose");
  d = good;
  d.tool_path[1].z() = NAN;
  expect_invalid(d, "non-finite tool path");
  d = good;
  d.moving_displacements.pop_back();
  expect_invalid(d, "fewer moving-point displacements than times");
  d = good;
  d.moving_displacements[7].translation().y() = NAN;
  expect_invalid(d, "non-finite moving-point displacement");
  HtmlViewOptions options;
  options.max_path_points = 1;
  EXPECT_FALSE(RenderHtmlView(good, options).ok());
  // An empty scene is a valid (if dull) page.
  EXPECT_TRUE(RenderHtmlView(HtmlViewData{}).ok());
}

TEST(HtmlViewTest, WritesAtomicallyAndNamesTheFile) {
  TempDir dir;
  const std::string path = dir / "view.html";
  ASSERT_TRUE(WriteHtmlView(path, SyntheticScene(1000)).ok());
  EXPECT_GT(fs::file_size(path), 100000u);

  HtmlViewData bad = SyntheticScene(1000);
  bad.times.pop_back();
  const std::string other = dir / "bad.html";
  const core::Status status = WriteHtmlView(other, bad);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find(other), std::string::npos) << status.message();
  EXPECT_FALSE(fs::exists(other));
  EXPECT_FALSE(WriteHtmlView(dir / "missing/folder/view.html", SyntheticScene(100)).ok());
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

// --- headless Chromium ------------------------------------------------------------

// The browser to test with: $QUADHAND_CHROMIUM or `chromium` on the PATH.
std::string FindChromium() {
  if (const char* env = std::getenv("QUADHAND_CHROMIUM"); env && *env) return env;
  const auto found = testing::RunCommand("command -v chromium");
  if (found.exit_code != 0) return "";
  std::string path = found.out;
  while (!path.empty() && (path.back() == '\n' || path.back() == ' ')) path.pop_back();
  return path;
}

struct BrowserRun {
  int exit_code = -1;
  std::string dom;
  std::string log;  // Chromium's stderr
};

// Loads `html_path` (with `fragment`) in a fresh headless profile that may not
// reach any network host, dumping the DOM after the page settled and taking a
// screenshot.
BrowserRun LoadInChromium(const std::string& chromium, const std::string& html_path, const std::string& fragment,
                          const std::string& screenshot, const TempDir& dir) {
  const std::string profile = dir / ("profile_" + std::to_string(std::rand()));
  const std::string flags =
      " --headless --no-sandbox --disable-gpu --use-angle=swiftshader --enable-unsafe-swiftshader"
      " --disable-quic --no-first-run --no-default-browser-check --disable-background-networking"
      " --disable-component-update --disable-sync --disable-extensions --mute-audio --hide-scrollbars"
      " --host-resolver-rules='MAP * ~NOTFOUND' --user-data-dir=" + profile +
      " --enable-logging=stderr --v=0 --virtual-time-budget=5000 --window-size=1024,768";
  const std::string url = "file://" + fs::absolute(html_path).string() + fragment;
  BrowserRun run;
  // --screenshot and --dump-dom in one run: the DOM goes to stdout.
  const auto result = testing::RunCommand("timeout 60 " + chromium + flags + " --screenshot=" + screenshot +
                                          " --dump-dom '" + url + "'");
  run.exit_code = result.exit_code;
  run.dom = result.out;
  run.log = result.err;
  return run;
}

// Lines Chromium logged from the page's console (it logs every level the
// same way), except the GL driver's performance notes.
std::vector<std::string> ConsoleLines(const std::string& log) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < log.size()) {
    std::size_t end = log.find('\n', start);
    if (end == std::string::npos) end = log.size();
    const std::string line = log.substr(start, end - start);
    if (line.find(":CONSOLE") != std::string::npos && line.find("GL Driver Message") == std::string::npos) {
      lines.push_back(line);
    }
    start = end + 1;
  }
  return lines;
}

TEST(HtmlViewTest, RendersInHeadlessChromiumWithoutErrors) {
  const std::string chromium = FindChromium();
  ASSERT_FALSE(chromium.empty()) << "Chromium is needed for this test and was not found: install it with "
                                    "`bash scripts/setup.sh` (Debian package chromium) or set QUADHAND_CHROMIUM";
  TempDir dir;
  const std::string page = dir / "view.html";
  ASSERT_TRUE(WriteHtmlView(page, SyntheticScene(60000)).ok());
  const std::string png = dir / "view.png";
  const BrowserRun run = LoadInChromium(chromium, page, "#selftest", png, dir);
  ASSERT_EQ(run.exit_code, 0) << run.log;

  EXPECT_EQ(Attribute(run.dom, "data-rendered"), "ok") << "the page did not finish its first frame\n" << run.dom.substr(0, 4000);
  EXPECT_EQ(Attribute(run.dom, "data-errors"), "") << "the page reported errors: "
                                                    << run.dom.substr(run.dom.find("qh-errors"), 2000);
  const auto console = ConsoleLines(run.log);
  EXPECT_TRUE(console.empty()) << "console output: " << console.front();
  // The first frame drew a scene, not an empty canvas.
  // (The headless window keeps some of its 768 pixels of height for itself.)
  const std::string canvas = Attribute(run.dom, "data-canvas-size");
  EXPECT_EQ(canvas.substr(0, 5), "1024x") << canvas;
  EXPECT_GT(std::atoi(canvas.substr(5).c_str()), 500) << canvas;
  EXPECT_GT(std::atof(Attribute(run.dom, "data-canvas-drawn").c_str()), 0.08);
  EXPECT_GT(std::atoi(Attribute(run.dom, "data-canvas-colours").c_str()), 50);
  // The legend lists every layer.
  for (const char* layer : {"obstacle cloud", "base path", "tool path", "insertion line", "robot at slider time",
                            "robot at 6 sampled times", "moving target's points"}) {
    EXPECT_NE(run.dom.find(layer), std::string::npos) << layer;
  }
  EXPECT_NE(run.dom.find("t = 0.00 s / 4.00 s"), std::string::npos);

  // A real screenshot: a PNG of the window size, far larger than a blank one.
  std::ifstream in(png, std::ios::binary);
  ASSERT_TRUE(in) << "no screenshot at " << png;
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 24u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto be32 = [&](std::size_t at) {
    return (std::uint32_t(std::uint8_t(bytes[at])) << 24) | (std::uint32_t(std::uint8_t(bytes[at + 1])) << 16) |
           (std::uint32_t(std::uint8_t(bytes[at + 2])) << 8) | std::uint32_t(std::uint8_t(bytes[at + 3]));
  };
  EXPECT_EQ(be32(16), 1024u);
  EXPECT_EQ(be32(20), 768u);
  EXPECT_GT(bytes.size(), 100u * 1024) << "the screenshot is suspiciously small (blank?)";
  if (const char* keep = std::getenv("QUADHAND_VIZ_KEEP"); keep && *keep) {
    fs::copy_file(page, std::string(keep) + ".html", fs::copy_options::overwrite_existing);
    fs::copy_file(png, std::string(keep) + ".png", fs::copy_options::overwrite_existing);
  }
}

// The checks above can fail: a page that logs an error and tries to load a
// remote image is caught by the same harness.
TEST(HtmlViewTest, HeadlessCheckCatchesErrorsAndRequests) {
  const std::string chromium = FindChromium();
  ASSERT_FALSE(chromium.empty()) << "Chromium is needed for this test and was not found: install it with "
                                    "`bash scripts/setup.sh` (Debian package chromium) or set QUADHAND_CHROMIUM";
  TempDir dir;
  auto html = RenderHtmlView(SyntheticScene(2000));
  ASSERT_TRUE(html.ok());
  const std::string injected =
      "<script>console.error('injected failure'); new Image().src = 'http://example.invalid/x.png';</script>";
  const std::size_t body_end = html->rfind("</body>");
  ASSERT_NE(body_end, std::string::npos);
  std::string broken = *html;
  broken.insert(body_end, injected);
  const std::string page = dir / "broken.html";
  std::ofstream(page) << broken;
  const BrowserRun run = LoadInChromium(chromium, page, "", dir / "broken.png", dir);
  ASSERT_EQ(run.exit_code, 0) << run.log;
  EXPECT_EQ(Attribute(run.dom, "data-errors"), "2") << run.dom.substr(0, 3000);
  EXPECT_NE(run.dom.find("error: injected failure"), std::string::npos);
  EXPECT_NE(run.dom.find("blocked (content security policy img-src): http://example.invalid/x.png"),
            std::string::npos);
  EXPECT_FALSE(ConsoleLines(run.log).empty());
}

}  // namespace
}  // namespace quadhand::viz
