// Command-line behaviour of quadhand-meshgen: a tolerance outside its range
// gives exit code 2, one line naming the option and its range, and no output
// folder (a micrometre-fine tessellation would run for minutes).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "support/run_command.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::RunCommand;

const std::string kMeshgen = std::string(QUADHAND_BIN_DIR) + "/quadhand-meshgen";

TEST(MeshgenCliTest, RefusesToleranceOutsideItsRangeWithOneLineAndNoOutput) {
  const fs::path out = fs::temp_directory_path() / ("quadhand_meshgen_" + std::to_string(getpid()));
  fs::remove_all(out);
  for (const char* tolerance : {"0", "-1", "nan", "1e-300", "1e-9", "1e300", "abc"}) {
    SCOPED_TRACE(tolerance);
    const auto r = RunCommand(kMeshgen + " --out " + out.string() + " --quiet --tolerance " + tolerance);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("--tolerance"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
  const auto help = RunCommand(kMeshgen + " --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("[1e-6, 1e-3]"), std::string::npos) << help.out;
}

}  // namespace
}  // namespace quadhand
