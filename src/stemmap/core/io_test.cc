#include "stemmap/core/io.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "stemmap/core/error.h"

namespace stemmap {
namespace {

namespace fs = std::filesystem;

fs::path TestDir() {
  const fs::path dir =
      fs::temp_directory_path() / ("stemmap_io_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

TEST(Io, AtomicWriteCreatesFolderAndLeavesNoTemporaries) {
  const fs::path dir = TestDir() / "a" / "b";
  WriteFileAtomic(dir / "x.txt", "hello");
  EXPECT_EQ(ReadFileToString(dir / "x.txt"), "hello");
  WriteFileAtomic(dir / "x.txt", "again");
  EXPECT_EQ(ReadFileToString(dir / "x.txt"), "again");
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1);
}

TEST(Io, ReadMissingFileNamesIt) {
  try {
    ReadFileToString("/nonexistent/stemmap/file.json");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/stemmap/file.json"), std::string::npos);
  }
}

TEST(Io, BadJsonIsAnInputError) {
  const fs::path path = TestDir() / "bad.json";
  WriteFileAtomic(path, "{not json");
  EXPECT_THROW(ReadJsonFile(path), InputError);
  WriteJsonAtomic(path, {{"a", 1}});
  EXPECT_EQ(ReadJsonFile(path)["a"], 1);
}

// A fuzzer's finding: get<int>() of a number beyond int's range is undefined behaviour, so such
// numbers are refused when the file is read, however deep they sit.
TEST(Io, NumbersBeyondAnIntAreRefused) {
  const fs::path path = TestDir() / "huge.json";
  WriteFileAtomic(path,
                  R"({"trees": [{"id": 111111111111111111111111111111111111111111111111111}]})");
  EXPECT_THROW(ReadJsonFile(path), InputError);
  WriteFileAtomic(path, std::string(100000, '[') + "-3e9" + std::string(100000, ']'));
  EXPECT_THROW(ReadJsonFile(path), InputError);
  WriteFileAtomic(path, R"({"x_m": 2.5e3, "n": 2000000000, "t": -1.5})");
  EXPECT_EQ(ReadJsonFile(path)["x_m"].get<double>(), 2500.0);
}

// Keys an options file has that no option has are found at any depth; a file an earlier run saved
// (perhaps another version's) is read with them ignored, one the user gave is refused.
TEST(Io, UnknownOptionKeysAreRefusedOrIgnored) {
  const nlohmann::json known = {{"a", 1}, {"b", {{"c", 2}, {"d", {3, 4}}}}};
  const fs::path path = "opts.json";
  EXPECT_NO_THROW(CheckNoUnknownKeys(path, {{"b", {{"c", 5}}}}, known, UnknownOptionKeys::kRefuse));
  const nlohmann::json typo = {{"a", 1}, {"b", {{"cc", 2}}}};
  try {
    CheckNoUnknownKeys(path, typo, known, UnknownOptionKeys::kRefuse);
    ADD_FAILURE() << "refused nothing";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'b.cc'"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(CheckNoUnknownKeys(path, typo, known, UnknownOptionKeys::kWarn));
}

}  // namespace
}  // namespace stemmap
