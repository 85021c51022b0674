#include "stemmap/core/run_folder.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <string>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap {
namespace {

namespace fs = std::filesystem;

fs::path TestDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("stemmap_run_folder_test_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void ExpectInputError(const fs::path& out, const std::string& words) {
  try {
    StagedRunFolder folder(out);
    FAIL() << out << " was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(StagedRunFolder, NothingAppearsUntilCommit) {
  const fs::path out = TestDir("new") / "run";
  StagedRunFolder folder(out);
  WriteFileAtomic(folder.staging() / "trees.csv", "tree_id\n");
  EXPECT_FALSE(fs::exists(out));
  folder.Commit({{"command", "test"}});
  EXPECT_TRUE(fs::exists(out / "trees.csv"));
  EXPECT_EQ(ReadJsonFile(out / kRunMarkerFile).at("command"), "test");
  EXPECT_FALSE(fs::exists(folder.staging()));
}

TEST(StagedRunFolder, AnEarlierRunIsReplacedWholeOnlyAtCommit) {
  const fs::path out = TestDir("again") / "run";
  WriteFileAtomic(out / kRunMarkerFile, "{}");
  WriteFileAtomic(out / "report.html", "old");
  {
    StagedRunFolder failed(out);
    WriteFileAtomic(failed.staging() / "trajectory.tum", "new");
    // No commit: a run that failed.
  }
  EXPECT_TRUE(fs::exists(out / "report.html")) << "the earlier run stays whole";
  EXPECT_FALSE(fs::exists(out / "trajectory.tum")) << "and gets nothing of the failed one";
  EXPECT_FALSE(fs::exists(StagingFolderFor(out))) << "nothing is left of a failed run";
  {
    StagedRunFolder stopped(out);
    stopped.KeepIfUnfinished();
    WriteFileAtomic(stopped.staging() / "trajectory.tum", "new");
  }
  EXPECT_TRUE(fs::exists(StagingFolderFor(out) / "trajectory.tum"));
  StagedRunFolder folder(out);
  EXPECT_FALSE(fs::exists(folder.staging() / "trajectory.tum")) << "a leftover is cleared";
  WriteFileAtomic(folder.staging() / "trees.csv", "new");
  folder.Commit({{"command", "test"}});
  EXPECT_TRUE(fs::exists(out / "trees.csv"));
  EXPECT_FALSE(fs::exists(out / "report.html")) << "nothing of the earlier run is left";
}

TEST(StagedRunFolder, ALeftoverNamedToGoOnFromIsKept) {
  const fs::path out = TestDir("resume") / "run";
  const fs::path staging = StagingFolderFor(out);
  WriteFileAtomic(staging / "keyframes.tum", "track");
  StagedRunFolder folder(out, staging);
  EXPECT_TRUE(fs::exists(folder.staging() / "keyframes.tum"));
}

TEST(StagedRunFolder, UnusableOutputsAreRefusedBeforeAnyWork) {
  const fs::path dir = TestDir("bad");
  WriteFileAtomic(dir / "file", "x");
  ExpectInputError(dir / "file", "is a file");
  WriteFileAtomic(dir / "photos" / "a.jpg", "x");
  ExpectInputError(dir / "photos", "files of something else");
  EXPECT_TRUE(fs::exists(dir / "photos" / "a.jpg"));
  if (::geteuid() != 0) {  // root writes anywhere
    fs::create_directories(dir / "locked");
    fs::permissions(dir / "locked", fs::perms::owner_read | fs::perms::owner_exec);
    ExpectInputError(dir / "locked" / "run", "cannot write");
    fs::permissions(dir / "locked", fs::perms::owner_all);
  }
  ExpectInputError(dir / "file" / "run", "cannot write");
}

}  // namespace
}  // namespace stemmap
