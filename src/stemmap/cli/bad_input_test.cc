// The binary against bad input: every case ends with its exit code and one line on stderr that
// names the cause (or a result flagged as partial), never a crash. The clips are made here from
// one short simulated capture, with FFmpeg's tool.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "stemmap/cli/test_renders.h"
#include "stemmap/core/io.h"
#include "stemmap/core/run_folder.h"

namespace stemmap {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  int exit_code = -1;
  std::string stderr_text;
  double seconds = 0.0;
};

fs::path Dir() {
  static const fs::path dir =
      fs::temp_directory_path() / ("stemmap_bad_input_" + std::to_string(::getpid()));
  return dir;
}

// Runs stemmap with `args`; with `signal` (INT, TERM), sends it that signal once `started`
// exists (a file the run makes after its start-up, so a loaded machine's slow start does not
// meet the signal before the handler), then after `after_s`.
Outcome RunStemmap(const std::string& args, const std::string& signal = "", double after_s = 0.0,
                   const fs::path& started = {}) {
  const fs::path err = Dir() / "stderr.txt";
  std::string cmd = fmt::format("'{}' {} > /dev/null 2> '{}'", STEMMAP_BINARY, args, err.string());
  if (!signal.empty()) {
    cmd += " & pid=$!;";
    if (!started.empty()) {
      cmd += fmt::format(" for i in $(seq 600); do [ -e '{}' ] && break; sleep 0.05; done;",
                         started.string());
    }
    cmd += fmt::format(" sleep {}; kill -{} $pid; wait $pid", after_s, signal);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const int status = std::system(cmd.c_str());
  Outcome o;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  o.stderr_text = ReadFileToString(err);
  return o;
}

void Ffmpeg(const std::string& args) {
  const std::string cmd = "ffmpeg -hide_banner -loglevel error -y " + args;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

std::string Quote(const fs::path& p) { return "'" + p.string() + "'"; }

// The last line of stderr: stemmap's error, alone on its line.
std::string LastLine(const std::string& text) {
  std::string t = text;
  while (!t.empty() && t.back() == '\n') t.pop_back();
  const size_t nl = t.rfind('\n');
  return nl == std::string::npos ? t : t.substr(nl + 1);
}

void ExpectRefused(const std::string& what, const std::string& args, int exit_code,
                   const std::vector<std::string>& words) {
  SCOPED_TRACE(what);
  const Outcome o = RunStemmap(args);
  EXPECT_EQ(o.exit_code, exit_code) << o.stderr_text;
  const std::string last = LastLine(o.stderr_text);
  EXPECT_EQ(last.rfind("stemmap: ", 0), 0u) << "the error comes last, as stemmap's: " << last;
  for (const std::string& w : words) {
    EXPECT_NE(last.find(w), std::string::npos) << "'" << w << "' not in: " << last;
  }
  for (const char* noise : {"[h264", "[mov", "OpenCV(", "terminate called", "Assertion"}) {
    EXPECT_EQ(o.stderr_text.find(noise), std::string::npos) << "library text on stderr";
  }
}

class BadInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::remove_all(Dir());
    fs::create_directories(Dir());
    if (std::system("ffmpeg -hide_banner -version > /dev/null 2>&1") != 0) return;
    have_ffmpeg_ = true;
    Simulate("plot", 1.1);
    Simulate("half", 0.5);
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(Dir(), ignored);
  }
  // The simulated captures, rendered once and shared by the tests (each runs in a process of its
  // own) and, where STEMMAP_TEST_RENDERS names a folder, by the builds (test_renders.h).
  static fs::path Plots() {
    return SharedRenders(fs::temp_directory_path() / "stemmap_test_renders") / "bad_input_v1";
  }
  static void Simulate(const std::string& name, double turns) {
    RenderedOnce(Plots(), name, std::to_string(::getpid()), [&](const fs::path& folder) {
      ASSERT_EQ(RunStemmap(fmt::format("simulate --seed 4 --width 480 --height 270 --fps 10 "
                                       "--seconds 9 --stills 0 --turns {} --out {}",
                                       turns, Quote(folder)))
                    .exit_code,
                0);
    });
  }
  static fs::path Plot() { return Plots() / "plot" / "video.mp4"; }
  // The plot's video through an FFmpeg filter or option set.
  static fs::path Derived(const std::string& name, const std::string& args) {
    const fs::path out = Dir() / name;
    Ffmpeg(
        fmt::format("-i {} {} -c:v libx264 -pix_fmt yuv420p {}", Quote(Plot()), args, Quote(out)));
    return out;
  }
  static std::string Track(const fs::path& video) {
    return fmt::format("track {} --hfov 65 --out {}", Quote(video), Quote(Dir() / "out"));
  }
  static bool have_ffmpeg_;
};
bool BadInput::have_ffmpeg_ = false;

TEST_F(BadInput, FilesThatAreNotVideos) {
  WriteFileAtomic(Dir() / "empty.mp4", "");
  ExpectRefused("empty", Track(Dir() / "empty.mp4"), 2, {"cannot open video", "damaged"});
  std::string noise(20000, '\0');
  for (size_t i = 0; i < noise.size(); ++i) noise[i] = static_cast<char>((i * 2654435761u) >> 13);
  WriteFileAtomic(Dir() / "random.mp4", noise);
  ExpectRefused("random bytes", Track(Dir() / "random.mp4"), 2, {"video"});
  WriteFileAtomic(Dir() / "notes.mov", "plot 7, north slope\n");
  ExpectRefused("text", Track(Dir() / "notes.mov"), 2, {"video"});
  ExpectRefused("missing", Track(Dir() / "nowhere.mp4"), 2, {"nowhere.mp4"});
  ExpectRefused("a folder", Track(Dir()), 2, {"error"});
  if (!have_ffmpeg_) GTEST_SKIP() << "the ffmpeg tool is not installed";
  Ffmpeg(fmt::format("-f lavfi -i sine=duration=2 -c:a aac {}", Quote(Dir() / "audio.m4a")));
  ExpectRefused("audio only", Track(Dir() / "audio.m4a"), 2, {"no decodable video stream"});
}

TEST_F(BadInput, AbsurdFlagsAndUnusableOutputsFailAtOnce) {
  if (!have_ffmpeg_) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const std::string video = Quote(Plot());
  const std::string out = Quote(Dir() / "out");
  ExpectRefused("negative arm", fmt::format("track {} --arm-radius -1 --out {}", video, out), 2,
                {"arm radius"});
  ExpectRefused("field of view", fmt::format("track {} --hfov 500 --out {}", video, out), 2,
                {"--hfov"});
  ExpectRefused("no frames tracked", fmt::format("track {} --track-fps 0 --out {}", video, out), 2,
                {"fps"});
  ExpectRefused("unknown flag", fmt::format("process {} --arm 1 --out {}", video, out), 2,
                {"--arm"});
  ExpectRefused("not a number", fmt::format("process {} --arm-radius one --out {}", video, out), 2,
                {"arm-radius"});
  WriteFileAtomic(Dir() / "a_file", "x");
  const Outcome o = RunStemmap(fmt::format("process {} --out {}", video, Quote(Dir() / "a_file")));
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(LastLine(o.stderr_text).find("is a file"), std::string::npos) << o.stderr_text;
  EXPECT_LT(o.seconds, 2.0) << "an unusable output is refused before any work";
}

TEST_F(BadInput, VideosThatAreNotAPlotCapture) {
  if (!have_ffmpeg_) GTEST_SKIP() << "the ffmpeg tool is not installed";
  ExpectRefused("static camera",
                Track(Derived("static.mp4", "-vf trim=end_frame=1,loop=loop=89:size=1,fps=10")), 2,
                {"does not turn"});
  ExpectRefused("half turn", Track(Plots() / "half" / "video.mp4"), 2, {"full turn"});
  ExpectRefused("dark", Track(Derived("dark.mp4", "-vf lutyuv=y=val*0.06")), 2,
                {"too dark", "daylight"});
  ExpectRefused("picture turned 90°", Track(Derived("turned.mp4", "-vf transpose=1")), 2,
                {"turned 90°", "transpose"});
  ExpectRefused("tiny", Track(Derived("tiny.mp4", "-vf scale=160:90")), 2, {"too small", "160x90"});
  ExpectRefused("two frames", Track(Derived("short.mp4", "-frames:v 2")), 2, {"too short"});
}

TEST_F(BadInput, DamagedFilesAreNamedAsSuch) {
  if (!have_ffmpeg_) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const std::string bytes = ReadFileToString(Plot());
  // A copy cut short: the index at the end is lost.
  WriteFileAtomic(Dir() / "cut.mp4", bytes.substr(0, bytes.size() * 3 / 10));
  ExpectRefused("cut short", Track(Dir() / "cut.mp4"), 2, {"damaged or incomplete"});
  // The same with the index first (as some phones write): the frames before the cut are read.
  const fs::path indexed = Dir() / "indexed.mp4";
  Ffmpeg(fmt::format("-i {} -c copy -movflags +faststart {}", Quote(Plot()), Quote(indexed)));
  const std::string indexed_bytes = ReadFileToString(indexed);
  WriteFileAtomic(Dir() / "indexed_cut.mp4", indexed_bytes.substr(0, indexed_bytes.size() / 3));
  ExpectRefused("index first, cut short", Track(Dir() / "indexed_cut.mp4"), 2,
                {"incomplete", "could be read"});
  // Zeros over a fifth of the data mid-file (some two seconds of frames): the tracks are bridged
  // across and the damage flagged in the summary; a failure must say the file is damaged.
  std::string damaged = indexed_bytes;
  std::fill(damaged.begin() + damaged.size() * 4 / 10, damaged.begin() + damaged.size() * 6 / 10,
            '\0');
  WriteFileAtomic(Dir() / "zeros.mp4", damaged);
  const Outcome o = RunStemmap(Track(Dir() / "zeros.mp4"));
  if (o.exit_code == 0) {
    const auto summary = ReadJsonFile(Dir() / "out" / "summary.json");
    EXPECT_GT(summary["track"]["video"]["damaged_frames"].get<int>() +
                  summary["track"]["video"]["corrupt_packets"].get<int>(),
              0);
    EXPECT_FALSE(summary["track"]["video"]["damaged_spans_s"].empty());
  } else {
    EXPECT_NE(LastLine(o.stderr_text).find("damaged"), std::string::npos) << o.stderr_text;
  }
}

TEST_F(BadInput, OtherWaysOfTurningStillGiveATrack) {
  if (!have_ffmpeg_) GTEST_SKIP() << "the ffmpeg tool is not installed";
  for (const auto& [name, args] : std::vector<std::pair<std::string, std::string>>{
           {"clockwise.mp4", "-vf reverse"}, {"fast.mp4", "-vf setpts=0.5*PTS -r 20"}}) {
    SCOPED_TRACE(name);
    const Outcome o = RunStemmap(Track(Derived(name, args)));
    EXPECT_EQ(o.exit_code, 0) << o.stderr_text;
  }
}

// Ctrl-C or a scheduler's SIGTERM mid-run: one line saying what was kept, the earlier run in
// --out untouched, the exit code of the signal.
TEST_F(BadInput, AStoppedRunSaysWhatWasKeptAndLeavesTheEarlierOne) {
  if (!have_ffmpeg_) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path out = Dir() / "kept";
  ASSERT_EQ(
      RunStemmap(fmt::format("track {} --hfov 65 --out {}", Quote(Plot()), Quote(out))).exit_code,
      0);
  const std::string before = ReadFileToString(out / "trajectory.tum");
  for (const auto& [signal, code] : {std::pair{"INT", 130}, std::pair{"TERM", 143}}) {
    SCOPED_TRACE(signal);
    // The track of the 9-s clip takes a few seconds; the signal comes while it runs, once its
    // staging folder is there (the one an earlier stopped run left is no sign of this one).
    fs::remove_all(StagingFolderFor(out));
    const Outcome o =
        RunStemmap(fmt::format("track {} --hfov 65 --out {}", Quote(Plot()), Quote(out)), signal,
                   0.3, StagingFolderFor(out));
    EXPECT_EQ(o.exit_code, code) << o.stderr_text;
    EXPECT_NE(LastLine(o.stderr_text).find("interrupted: nothing of this run was written"),
              std::string::npos)
        << o.stderr_text;
    EXPECT_EQ(ReadFileToString(out / "trajectory.tum"), before);
  }
}

}  // namespace
}  // namespace stemmap
