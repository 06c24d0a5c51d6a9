// Command-line behaviour of quadhand-sdfgen: outputs, probe/info, exit codes
// and clean failures on bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/geometry/sdf_grid.h"
#include "support/run_command.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::RunCommand;

const std::string kSdfgen = std::string(QUADHAND_BIN_DIR) + "/quadhand-sdfgen";

class SdfgenTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("quadhand_sdfgen_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  // A 0.1 m cube centred at the origin, written as an OFF file.
  std::string WriteCube() {
    geometry::Box box;
    box.size = Vec3::Constant(0.1);
    const std::string path = Path("cube.off");
    EXPECT_TRUE(geometry::WriteMesh(path, geometry::TessellateBox(box)).ok());
    return path;
  }

  // Expects exit code 2, exactly one stderr line mentioning `fragment`, and
  // nothing at all in the output directory `out` (if given).
  void ExpectBadInput(const std::string& args, const std::string& fragment, const std::string& out = "") {
    const auto result = RunCommand(kSdfgen + " " + args);
    EXPECT_EQ(result.exit_code, 2) << args << "\n" << result.err;
    EXPECT_EQ(CountLines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(fragment), std::string::npos) << result.err;
    if (!out.empty() && fs::exists(out)) {
      EXPECT_TRUE(fs::is_empty(out)) << "partial output in " << out;
    }
  }

  fs::path dir_;
};

TEST_F(SdfgenTest, HelpDocumentsEveryMode) {
  const auto result = RunCommand(kSdfgen + " --help");
  EXPECT_EQ(result.exit_code, 0);
  for (const char* word : {"--urdf", "--mesh", "--link", "--out", "--resolution", "--padding", "probe", "info"}) {
    EXPECT_NE(result.out.find(word), std::string::npos) << word;
  }
}

TEST_F(SdfgenTest, MeshToSdfThenProbeAndInfo) {
  const std::string cube = WriteCube();
  const std::string out = Path("out");
  const auto gen = RunCommand(kSdfgen + " --mesh " + cube + " --link cube --out " + out +
                              " --resolution 0.005 --padding 0.03 --threads 2");
  ASSERT_EQ(gen.exit_code, 0) << gen.err;
  const std::string file = out + "/cube.qhsdf";
  ASSERT_TRUE(fs::exists(file));
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator{}), 1);

  // Face centre region: exact distance 0.02 - 0.05... along +x: 0.07 - 0.05 = 0.02.
  const auto probe = RunCommand(kSdfgen + " probe " + file + " 0.07 0 0");
  ASSERT_EQ(probe.exit_code, 0) << probe.err;
  std::istringstream values(probe.out);
  double d = 0, gx = 0, gy = 0, gz = 0;
  values >> d >> gx >> gy >> gz;
  EXPECT_NEAR(d, 0.02, 1e-4);
  EXPECT_NEAR(gx, 1.0, 1e-3);
  EXPECT_NEAR(gy, 0.0, 1e-3);

  const auto from_stdin = RunCommand(kSdfgen + " probe " + file, "0 0 0\n\n0.07 0 0\n1 1 1\n");
  ASSERT_EQ(from_stdin.exit_code, 0) << from_stdin.err;
  EXPECT_EQ(CountLines(from_stdin.out), 3);
  std::istringstream first(from_stdin.out);
  first >> d;
  EXPECT_NEAR(d, -0.05, 1e-4);  // centre of the cube: inside

  const auto bad_line = RunCommand(kSdfgen + " probe " + file, "0 0 zero\n");
  EXPECT_EQ(bad_line.exit_code, 2);
  EXPECT_NE(bad_line.err.find("line 1"), std::string::npos);

  const auto info = RunCommand(kSdfgen + " info " + file);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("link: cube"), std::string::npos);
  EXPECT_NE(info.out.find("resolution: 0.005"), std::string::npos);
  EXPECT_NE(info.out.find("format_version: 2"), std::string::npos);
}

TEST_F(SdfgenTest, RejectsBadInputWithOneLineAndNoFiles) {
  const std::string out = Path("out");
  ExpectBadInput("--mesh /nonexistent.stl --link x --out " + out, "/nonexistent.stl", out);
  ExpectBadInput("--urdf /nonexistent.urdf --out " + out, "/nonexistent.urdf", out);
  {
    std::ofstream garbage(Path("garbage.stl"));
    garbage << "this is not a mesh\n";
  }
  ExpectBadInput("--mesh " + Path("garbage.stl") + " --link x --out " + out, "garbage.stl", out);
  {
    std::ofstream urdf(Path("broken.urdf"));
    urdf << "<robot name='r'><link name='a'>";
  }
  ExpectBadInput("--urdf " + Path("broken.urdf") + " --out " + out, "broken.urdf", out);
  const std::string cube = WriteCube();
  ExpectBadInput("--mesh " + cube + " --link x --out " + out + " --resolution -1", "resolution", out);
  ExpectBadInput("--mesh " + cube + " --link x --out " + out + " --resolution nan", "resolution", out);
  // A resolution of 1e300 put the grid's nodes at infinity, and CGAL's exact
  // distance predicates abort the process (SIGFPE) on an infinite point.
  ExpectBadInput("--mesh " + cube + " --link x --out " + out + " --resolution 1e300", "resolution must be in (0, 1] m", out);
  ExpectBadInput("--mesh " + cube + " --link x --out " + out + " --padding 1e300", "padding must be in [0, 10] m", out);
  ExpectBadInput("--mesh " + cube + " --link x --out " + out + " --threads 100000", "num_threads must be in [0, 256]", out);
  ExpectBadInput("--mesh " + cube + " --out " + out, "--link", out);
  ExpectBadInput("--out " + out, "--urdf", out);
  ExpectBadInput("--mesh " + cube + " --link x --out " + out + " --bogus", "bogus", out);
  ExpectBadInput("probe /nonexistent.qhsdf 0 0 0", "/nonexistent.qhsdf");
  ExpectBadInput("probe " + cube + " 0 0", "three");
  ExpectBadInput("info " + cube, "cube.off");
  // A grid too large is refused before the first line of progress (it came
  // after the info line, two lines in all), naming the URDF and the link.
  {
    std::ofstream urdf(Path("huge.urdf"));
    urdf << "<robot name='r'><link name='a'><collision><geometry><box size='900 1 1'/></geometry></collision>"
            "</link></robot>";
  }
  ExpectBadInput("--urdf " + Path("huge.urdf") + " --out " + out, "huge.urdf#a: the grid would have more", out);
}

TEST_F(SdfgenTest, OpenMeshNeedsUnsigned) {
  // A cube with one face missing.
  geometry::Box box;
  box.size = Vec3::Constant(0.1);
  geometry::TriangleMesh open = geometry::TessellateBox(box);
  open.triangles.pop_back();
  open.triangles.pop_back();
  const std::string path = Path("open.off");
  ASSERT_TRUE(geometry::WriteMesh(path, open).ok());
  const std::string out = Path("out");
  ExpectBadInput("--mesh " + path + " --link open --out " + out + " --resolution 0.01 --padding 0.02",
                 "open.off", out);
  const auto result = RunCommand(kSdfgen + " --mesh " + path + " --link open --out " + out +
                                 " --resolution 0.01 --padding 0.02 --unsigned -q");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  auto grid = geometry::SdfGrid::Load(out + "/open.qhsdf");
  ASSERT_TRUE(grid.ok());
  EXPECT_FALSE(grid->info().is_signed);
}

// The CAD-export test robot (tests/data/cad_robot): the reference robot with
// a reversed duplicate face, a sliver, a crack under the tolerance and a
// two-shell mesh inside the base. Repaired, its SDFs are the reference
// robot's, value for value; each repair is one line naming the file and link.
TEST_F(SdfgenTest, CadExportDefectsGiveTheReferenceSdfsBitForBit) {
  const std::string root = QUADHAND_SOURCE_DIR;
  const std::string reference = Path("reference"), cad = Path("cad");
  const std::string args = " --resolution 0.005 --padding 0.05";
  ASSERT_EQ(RunCommand(kSdfgen + " -q --urdf " + root + "/meshes/quadhand/quadhand.urdf --out " + reference + args)
                .exit_code,
            0);
  const auto r = RunCommand(kSdfgen + " --urdf " + root + "/tests/data/cad_robot/cad_robot.urdf --out " + cad + args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("link1_fin.stl' (link 'link1') repaired: removed 1 pair of reversed duplicate faces"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("link2_sliver_crack.stl' (link 'link2') repaired: merged 2 vertices"), std::string::npos)
      << r.err;
  for (const char* link : {"base_link", "link1", "link2", "link3", "battery"}) {
    auto a = geometry::SdfGrid::Load(reference + "/" + link + ".qhsdf");
    auto b = geometry::SdfGrid::Load(cad + "/" + link + ".qhsdf");
    ASSERT_TRUE(a.ok() && b.ok()) << link;
    EXPECT_EQ(a->info().dims, b->info().dims) << link;
    EXPECT_EQ(a->info().origin, b->info().origin) << link;
    EXPECT_TRUE(a->values() == b->values()) << link << ": the repaired mesh's SDF differs";
  }
}

TEST_F(SdfgenTest, AMeshWithARealHoleIsRefusedWithTheTrueDiagnosis) {
  const std::string out = Path("out");
  ExpectBadInput("--urdf " + std::string(QUADHAND_SOURCE_DIR) + "/tests/data/cad_robot/cad_robot_holed.urdf --out " +
                     out + " --resolution 0.005 --padding 0.05",
                 "link2_holed.stl' does not bound a volume, even repaired: not closed: 1 hole (a border of 3 edges",
                 out);
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(SdfgenTest, BadRepairTolerancesAndAMeshOfOnlyDegenerateFacesAreRefused) {
  const std::string cube = WriteCube(), out = Path("out");
  const std::string args = " --link cube --out " + out + " --resolution 0.01 --padding 0.02";
  ExpectBadInput("--mesh " + cube + args + " --repair-tolerance 0", "repair tolerance 0 m must be in (0, 0.001]", out);
  ExpectBadInput("--mesh " + cube + args + " --repair-tolerance nan", "repair tolerance nan m", out);
  ExpectBadInput("--mesh " + cube + " --link cube --out " + out + " --resolution 0.0005 --padding 0.02 --repair-tolerance 0.0008",
                 "the repair tolerance 0.0008 m is larger than the SDF resolution 0.0005 m", out);
  EXPECT_FALSE(fs::exists(out));
  // Within the bounds it is used (and the cube needs no repair).
  const auto ok = RunCommand(kSdfgen + " -q --mesh " + cube + args + " --repair-tolerance 0.0001");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;

  // Two triangles whose corners lie on lines: no surface at all.
  geometry::TriangleMesh needles;
  needles.vertices = {Vec3(0, 0, 0), Vec3(0.05, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0.05, 0), Vec3(0, 0.1, 0)};
  needles.triangles = {Eigen::Vector3i(0, 1, 2), Eigen::Vector3i(0, 3, 4)};
  const std::string path = Path("needles.stl");
  ASSERT_TRUE(geometry::WriteMesh(path, needles).ok());
  const std::string out2 = Path("out2");
  ExpectBadInput("--mesh " + path + " --link needles --out " + out2,
                 "needles.stl (link 'needles'): does not bound a volume, even repaired: every one of its 2 faces is "
                 "degenerate",
                 out2);
  EXPECT_FALSE(fs::exists(out2));
}

// The grids are computed before the output folder is made: a run killed
// while computing (SIGKILL: nothing can clean up) leaves no --out behind.
TEST_F(SdfgenTest, AKilledRunLeavesNoOutputFolder) {
  const std::string out = Path("killed");
  const auto r = RunCommand("timeout -s KILL 1.5 " + kSdfgen + " -q --urdf " + std::string(QUADHAND_SOURCE_DIR) +
                            "/meshes/quadhand/quadhand.urdf --out " + out + " --resolution 0.0008 --threads 1");
  EXPECT_NE(r.exit_code, 0) << "finished within the second and a half: the test needs a slower run";
  EXPECT_FALSE(fs::exists(out));
  // A folder that cannot be made still fails at once.
  ExpectBadInput("--urdf " + std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf --out /proc/sdf",
                 "/proc/sdf");
}

TEST_F(SdfgenTest, TruncatedFileIsRejected) {
  const std::string cube = WriteCube();
  const std::string out = Path("out");
  ASSERT_EQ(RunCommand(kSdfgen + " -q --mesh " + cube + " --link cube --out " + out +
                       " --resolution 0.01 --padding 0.02").exit_code, 0);
  const std::string file = out + "/cube.qhsdf";
  fs::resize_file(file, fs::file_size(file) - 100);
  ExpectBadInput("info " + file, "truncated");
  ExpectBadInput("probe " + file + " 0 0 0", "truncated");
}

// package:// URIs of a URDF kept apart from its package: unresolved (exit 2
// naming the package) until --package-path names the folder holding it.
TEST_F(SdfgenTest, PackagePathResolvesPackageUris) {
  fs::create_directories(dir_ / "packages" / "parts");
  fs::create_directories(dir_ / "description");
  fs::copy_file(WriteCube(), dir_ / "packages" / "parts" / "cube.off");
  {
    std::ofstream urdf(Path("description/robot.urdf"));
    urdf << "<robot name=\"r\"><link name=\"base\"><collision><geometry>"
            "<mesh filename=\"package://parts/cube.off\"/></geometry></collision></link></robot>\n";
  }
  const std::string out = Path("out");
  ExpectBadInput("--urdf " + Path("description/robot.urdf") + " --out " + out + " --resolution 0.01",
                 "package 'parts' not found", out);
  ExpectBadInput("--urdf " + Path("description/robot.urdf") + " --out " + out + " --package-path " +
                     Path("nowhere"),
                 "nowhere", out);
  const auto found = RunCommand(kSdfgen + " --urdf " + Path("description/robot.urdf") + " --out " + out +
                                " --resolution 0.01 -q --package-path " + Path("packages"));
  EXPECT_EQ(found.exit_code, 0) << found.err;
  EXPECT_TRUE(fs::exists(out + "/base.qhsdf"));
}

// A link's name becomes a file name: one that would leave --out (or is no
// file name at all) is refused before any folder or file is made.
TEST_F(SdfgenTest, LinkNamesThatAreNoFileNamesAreRefused) {
  for (const std::string name : {"../../evil", "a/b", ".."}) {
    {
      std::ofstream urdf(Path("evil.urdf"));
      urdf << "<robot name=\"r\"><link name=\"" << name
           << "\"><collision><geometry><box size=\"0.1 0.1 0.1\"/></geometry></collision></link></robot>\n";
    }
    const std::string out = Path("deep/out");
    ExpectBadInput("--urdf " + Path("evil.urdf") + " --out " + out + " --resolution 0.01", "cannot be a file name");
    EXPECT_FALSE(fs::exists(Path("deep"))) << name;
    EXPECT_FALSE(fs::exists(dir_.parent_path() / "evil.qhsdf")) << name;
  }
}

}  // namespace
}  // namespace quadhand
