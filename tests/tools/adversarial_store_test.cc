// The adversarial checks of issue 22 (locks, integrity, foreign folders,
// stale inputs and temporaries), run against the graphslam binary:
//
//   - two writers at once on one store (`ingest -o S`) and on one job folder
//     (`run -o OUT`), 20 trials each: every run either succeeds or fails with
//     the lock message (exit 3) and the result is byte for byte the output of
//     ONE of the two writers (zero silent mixes). Which one wins depends on
//     scheduling, so the assertions hold for every interleaving;
//   - deterministic lock conflicts: the test holds the lock itself
//     (storage/directory_lock.h; flock conflicts between open file
//     descriptions, so a child process sees it held) and starts a writer or a
//     reader, which must fail at once naming this process's pid;
//   - a damaged store for every file kind: `solve STORE` exits 2 naming the
//     file (scans files: tests/storage/chunk_store_integrity_test.cc);
//   - a foreign folder as `ingest -o` / `solve --workdir`: exit 2 naming it,
//     nothing deleted;
//   - `solve IN --workdir W --resume` after IN was replaced by a file of the
//     same size and mtime: the new input is solved, not the old store;
//   - temporaries a killed writer left are removed by the next writer of a
//     store, a workdir or a job folder; other files stay.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "storage/chunk_store.h"
#include "storage/directory_lock.h"
#include "storage/file_checksum.h"
#include "storage/native_log_reader.h"
#include "tests/testing/random_problem.h"
#include "tests/testing/subprocess.h"

namespace graphslam {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using storage::DirectoryLock;
using testing::RunGraphslam;
using testing::SpawnGraphslamRedirected;
using testing::WaitForExit;

constexpr int kTrials = 20;

std::string Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// Every regular file below `dir` (relative path -> bytes), but the lock file.
std::map<std::string, std::string> Snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file() || entry.path().filename() == storage::kDirectoryLockName)
      continue;
    files[fs::relative(entry.path(), dir).string()] = Read(entry.path());
  }
  return files;
}

class AdversarialStore : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("graphslam_adversarial_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    for (int k = 0; k < 2; ++k) {
      testing::RandomProblemOptions options;
      options.num_poses = 80;
      options.num_features = 25;
      options.seed = 100 + static_cast<uint32_t>(k);
      inputs_[k] = (root_ / ("input" + std::to_string(k) + ".graphslam")).string();
      ASSERT_TRUE(
          storage::WriteNativeLog(testing::MakeRandomProblem(options).problem, inputs_[k]).ok());
      jobs_[k] = (root_ / ("job" + std::to_string(k) + ".yaml")).string();
      std::ofstream(jobs_[k]) << "output: unused\nthreads: 1\n"
                                 "solver: {max_iterations: 2, initialization: odometry}\n"
                                 "runs:\n  - name: campus\n    format: simulate\n"
                                 "    simulate: {poses: 20, runs: 1, seed: "
                              << 7 + k << "}\n";
    }
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  void SetUp() override {
    ASSERT_TRUE(fs::exists(testing::GraphslamBinary())) << testing::GraphslamBinary();
    dir_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }

  fs::path Path(const std::string& name) const { return dir_ / name; }

  // Runs graphslam with stderr to a file; the exit code, stderr in *err.
  int Run(const std::vector<std::string>& args, std::string* err = nullptr) const {
    const std::string log = Path("stderr.txt").string();
    const int code = WaitForExit(SpawnGraphslamRedirected(args, log));
    if (err != nullptr) *err = Read(log);
    return code;
  }

  // A complete store of input k in `store`.
  void Ingest(int k, const fs::path& store) const {
    std::string err;
    ASSERT_EQ(Run({"ingest", inputs_[k], "-o", store.string(), "-q", "--chunk-observations",
                   "100"},
                  &err),
              0)
        << err;
  }

  static inline fs::path root_;
  static inline std::string inputs_[2];
  static inline std::string jobs_[2];
  fs::path dir_;
};

const std::string kLocked = "locked by another graphslam process (pid ";
const std::string kMyPid = "pid " + std::to_string(::getpid()) + ")";

// Two ingests of different inputs into one store at once, kTrials times.
TEST_F(AdversarialStore, ConcurrentIngestsNeverMix) {
  std::map<std::string, std::string> reference[2];
  for (int k = 0; k < 2; ++k) {
    Ingest(k, Path("reference" + std::to_string(k)));
    reference[k] = Snapshot(Path("reference" + std::to_string(k)));
    ASSERT_FALSE(reference[k].empty());
  }
  int conflicts = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const fs::path store = Path("store");
    fs::remove_all(store);
    pid_t pid[2];
    for (int k = 0; k < 2; ++k)
      pid[k] = SpawnGraphslamRedirected({"ingest", inputs_[k], "-o", store.string(), "-q",
                                         "--chunk-observations", "100"},
                                        Path("err" + std::to_string(k)).string());
    int code[2];
    for (int k = 0; k < 2; ++k) code[k] = WaitForExit(pid[k]);
    ASSERT_TRUE(code[0] == 0 || code[1] == 0) << "trial " << trial;
    for (int k = 0; k < 2; ++k) {
      if (code[k] == 0) continue;
      ++conflicts;
      EXPECT_EQ(code[k], 3) << "trial " << trial;
      EXPECT_THAT(Read(Path("err" + std::to_string(k))), HasSubstr(kLocked)) << "trial " << trial;
    }
    // Exactly one writer's store, every file (problem, chunks, manifest).
    const std::map<std::string, std::string> result = Snapshot(store);
    std::string differs;
    for (int k = 0; k < 2; ++k) {
      differs += " vs " + std::to_string(k) + ":";
      for (const auto& [name, bytes] : result)
        if (!reference[k].count(name) || reference[k].at(name) != bytes) differs += " " + name;
      for (const auto& [name, bytes] : reference[k])
        if (!result.count(name)) differs += " -" + name;
    }
    EXPECT_TRUE(result == reference[0] || result == reference[1])
        << "trial " << trial << ": the store mixes the two ingests (exit codes " << code[0]
        << ", " << code[1] << "; files" << differs << ")";
  }
  RecordProperty("lock_conflicts", conflicts);
}

// Two jobs with different runs into one output folder at once, kTrials times.
TEST_F(AdversarialStore, ConcurrentJobsNeverMix) {
  const std::vector<std::string> compared = {"graph.g2o", "features.csv", "trajectories/campus.tum"};
  std::vector<std::string> reference[2];
  for (int k = 0; k < 2; ++k) {
    const fs::path out = Path("reference" + std::to_string(k));
    std::string err;
    ASSERT_EQ(Run({"run", jobs_[k], "-o", out.string(), "-q"}, &err), 0) << err;
    for (const std::string& file : compared) reference[k].push_back(Read(out / file));
    ASSERT_FALSE(reference[k][0].empty());
  }
  ASSERT_NE(reference[0], reference[1]);
  int conflicts = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const fs::path out = Path("out");
    fs::remove_all(out);
    pid_t pid[2];
    for (int k = 0; k < 2; ++k)
      pid[k] = SpawnGraphslamRedirected({"run", jobs_[k], "-o", out.string(), "-q"},
                                        Path("err" + std::to_string(k)).string());
    int code[2];
    for (int k = 0; k < 2; ++k) code[k] = WaitForExit(pid[k]);
    ASSERT_TRUE(code[0] == 0 || code[1] == 0) << "trial " << trial;
    for (int k = 0; k < 2; ++k) {
      if (code[k] == 0) continue;
      EXPECT_EQ(code[k], 3) << "trial " << trial;
      EXPECT_THAT(Read(Path("err" + std::to_string(k))), HasSubstr(kLocked)) << "trial " << trial;
    }
    conflicts += (code[0] != 0) + (code[1] != 0);
    std::vector<std::string> result;
    for (const std::string& file : compared) result.push_back(Read(out / file));
    EXPECT_TRUE(result == reference[0] || result == reference[1])
        << "trial " << trial << ": the job folder mixes the two jobs";
  }
  RecordProperty("lock_conflicts", conflicts);
}

// Deterministic: the test holds the lock while a writer starts.
TEST_F(AdversarialStore, WritersFailAtOnceWhileTheLockIsHeld) {
  const fs::path store = Path("store");
  Ingest(0, store);
  const std::map<std::string, std::string> before = Snapshot(store);
  {
    StatusOr<DirectoryLock> held = DirectoryLock::Acquire(store.string(), DirectoryLock::Mode::kExclusive);
    ASSERT_TRUE(held.ok()) << held.status().ToString();
    std::string err;
    EXPECT_EQ(Run({"ingest", inputs_[1], "-o", store.string(), "-q"}, &err), 3);
    EXPECT_THAT(err, HasSubstr(kLocked));
    EXPECT_THAT(err, HasSubstr(kMyPid));
    // A writing solve (its checkpoint goes into STORE) and a reading one.
    EXPECT_EQ(Run({"solve", store.string(), "-q"}, &err), 3);
    EXPECT_THAT(err, HasSubstr(kMyPid));
    EXPECT_EQ(Run({"solve", store.string(), "-q", "--checkpoint", Path("c.json").string()}, &err),
              3);
    EXPECT_THAT(err, HasSubstr(kMyPid));
    EXPECT_EQ(Snapshot(store), before);
  }
  {
    // Readers share: a reading solve runs while a writer is refused.
    StatusOr<DirectoryLock> shared = DirectoryLock::Acquire(store.string(), DirectoryLock::Mode::kShared);
    ASSERT_TRUE(shared.ok());
    std::string err;
    EXPECT_EQ(Run({"solve", store.string(), "-q", "--checkpoint", Path("c.json").string()}, &err) % 4,
              0)
        << err;
    EXPECT_EQ(Run({"ingest", inputs_[1], "-o", store.string(), "-q"}, &err), 3);
    EXPECT_THAT(err, HasSubstr(kLocked));
    EXPECT_EQ(Snapshot(store), before);
  }
  const fs::path workdir = Path("workdir");
  fs::create_directories(workdir);
  const fs::path out = Path("out");
  fs::create_directories(out);
  StatusOr<DirectoryLock> w = DirectoryLock::Acquire(workdir.string(), DirectoryLock::Mode::kExclusive);
  StatusOr<DirectoryLock> o = DirectoryLock::Acquire(out.string(), DirectoryLock::Mode::kExclusive);
  ASSERT_TRUE(w.ok() && o.ok());
  std::string err;
  EXPECT_EQ(Run({"solve", inputs_[0], "--workdir", workdir.string(), "-q"}, &err), 3);
  EXPECT_THAT(err, HasSubstr(kMyPid));
  EXPECT_EQ(Run({"run", jobs_[0], "-o", out.string(), "-q"}, &err), 3);
  EXPECT_THAT(err, HasSubstr(kMyPid));
  EXPECT_FALSE(fs::exists(out / ".job"));
}

// Every file kind of a store, damaged: `solve STORE` exits 2 naming the file.
TEST_F(AdversarialStore, DamagedStoreOfEveryFileKindIsRejected) {
  struct Damage {
    std::string name;
    std::string file;  // relative to the store; named in the error
    std::function<void(const fs::path&)> apply;
  };
  auto change_digit = [](const fs::path& path, const std::string& after) {
    std::string text = Read(path);
    const size_t at = text.find(after);
    ASSERT_NE(at, std::string::npos) << after;
    const size_t digit = text.find_first_of("123456789", at + after.size());
    text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
    Write(path, text);
  };
  const std::vector<Damage> damages = {
      {"problem line deleted", "problem.graphslam",
       [](const fs::path& p) {
         std::string text = Read(p);
         const size_t line = text.find("\nPOSE");
         text.erase(line, text.find('\n', line + 1) - line);
         Write(p, text);
       }},
      {"problem digit changed", "problem.graphslam",
       [&](const fs::path& p) { change_digit(p, "\nFEATURE "); }},
      {"manifest edited to fewer chunks", "MANIFEST.json",
       [](const fs::path& p) {
         nlohmann::json m = nlohmann::json::parse(Read(p));
         const nlohmann::json last = m["chunks"].back();
         m["chunks"].erase(m["chunks"].size() - 1);
         m["num_chunks"] = m["num_chunks"].get<int64_t>() - 1;
         for (const char* key : {"features", "observations", "bytes"})
           m[std::string("total_") + key] =
               m[std::string("total_") + key].get<int64_t>() - last[key].get<int64_t>();
         Write(p, m.dump(2));
       }},
      {"manifest digit changed", "MANIFEST.json",
       [&](const fs::path& p) { change_digit(p, "\"features\": "); }},
      {"chunk byte changed", "000001.gsc",
       [](const fs::path& p) {
         std::string bytes = Read(p);
         bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
         Write(p, bytes);
       }},
      {"chunk deleted", "000001.gsc", [](const fs::path& p) { fs::remove(p); }},
  };
  for (const Damage& damage : damages) {
    const fs::path store = Path("store");
    fs::remove_all(store);
    Ingest(0, store);
    const fs::path file = damage.file.find(".gsc") != std::string::npos
                              ? store / "chunks" / damage.file
                              : store / damage.file;
    damage.apply(file);
    std::string err;
    EXPECT_EQ(Run({"solve", store.string(), "-q"}, &err), 2) << damage.name << ": " << err;
    EXPECT_THAT(err, HasSubstr(damage.file)) << damage.name;
  }
}

// A folder that is not a store of ours is refused as -o / --workdir and
// keeps every file.
TEST_F(AdversarialStore, ForeignFolderAsOutputIsRefusedAndKept) {
  const fs::path folder = Path("my_files");
  Write(folder / "scans" / "holiday.jpg", "photo");
  Write(folder / "work" / "thesis.tex", "thesis");
  Write(folder / "notes.txt", "notes");
  const std::map<std::string, std::string> before = Snapshot(folder);
  std::string err;
  EXPECT_EQ(Run({"ingest", inputs_[0], "-o", folder.string(), "-q"}, &err), 2);
  EXPECT_THAT(err, HasSubstr(folder.string()));
  EXPECT_THAT(err, HasSubstr("not a graphslam chunk store"));
  EXPECT_EQ(Run({"solve", inputs_[0], "--workdir", folder.string(), "-q"}, &err), 2);
  EXPECT_THAT(err, HasSubstr(folder.string()));
  EXPECT_EQ(Snapshot(folder), before);
  EXPECT_EQ(std::distance(fs::directory_iterator(folder), fs::directory_iterator()), 3);
}

// The input replaced by another of the same size and mtime: --resume must
// not reuse the store of the old one.
TEST_F(AdversarialStore, WorkdirResumeIdentifiesTheInputByContent) {
  const fs::path input = Path("input.graphslam");
  fs::copy_file(inputs_[0], input);
  const fs::path workdir = Path("workdir");
  std::string err;
  ASSERT_EQ(Run({"solve", input.string(), "--workdir", workdir.string(), "-q"}, &err) % 4, 0)
      << err;
  struct stat before {};
  ASSERT_EQ(::stat(input.c_str(), &before), 0);
  // Same size: one digit of the last measurement changed.
  std::string text = Read(input);
  size_t at = text.rfind('\n', text.size() - 2);
  ASSERT_NE(at, std::string::npos);
  for (int field = 0; field < 4; ++field) at = text.find(' ', at + 1);
  const size_t digit = text.find_first_of("123456789", at);
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
  Write(input, text);
  const struct timespec times[2] = {before.st_atim, before.st_mtim};
  ASSERT_EQ(::utimensat(AT_FDCWD, input.c_str(), times, 0), 0);
  ASSERT_EQ(fs::file_size(input), static_cast<uintmax_t>(before.st_size));

  ASSERT_EQ(Run({"solve", input.string(), "--workdir", workdir.string(), "--resume", "-q",
                 "--report", Path("resumed.json").string()},
                &err) %
                4,
            0)
      << err;
  // The same result as a fresh solve of the new input.
  ASSERT_EQ(Run({"solve", input.string(), "--workdir", Path("fresh").string(), "-q", "--report",
                 Path("fresh.json").string()},
                &err) %
                4,
            0)
      << err;
  EXPECT_EQ(nlohmann::json::parse(Read(Path("resumed.json"))).at("final_chi2"),
            nlohmann::json::parse(Read(Path("fresh.json"))).at("final_chi2"));
  StatusOr<std::unique_ptr<storage::DiskChunkSource>> store =
      storage::DiskChunkSource::Open(workdir.string());
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  StatusOr<storage::FileChecksum> now = storage::IdentifyInput(input.string());
  ASSERT_TRUE(now.ok());
  EXPECT_EQ((*store)->input(), *now) << "the workdir still holds the store of the old input";
}

// Temporaries a killed writer left go with the next writer; others' files stay.
TEST_F(AdversarialStore, StaleTemporariesAreRemovedOnResume) {
  const fs::path workdir = Path("workdir");
  std::string err;
  ASSERT_EQ(Run({"solve", inputs_[0], "--workdir", workdir.string(), "-q"}, &err) % 4, 0) << err;
  Write(workdir / "checkpoint.json.tmp-999999", "stale");
  Write(workdir / "chunks" / "000000.gsc.tmp-999998", "stale");
  ASSERT_EQ(Run({"solve", inputs_[0], "--workdir", workdir.string(), "--resume", "-q"}, &err) % 4,
            0)
      << err;
  EXPECT_FALSE(fs::exists(workdir / "checkpoint.json.tmp-999999"));
  EXPECT_FALSE(fs::exists(workdir / "chunks" / "000000.gsc.tmp-999998"));

  const fs::path store = Path("store");
  Ingest(0, store);
  Write(store / "checkpoint.json.tmp-999997", "stale");
  ASSERT_EQ(Run({"solve", store.string(), "--resume", "-q"}, &err) % 4, 0) << err;
  EXPECT_FALSE(fs::exists(store / "checkpoint.json.tmp-999997"));

  const fs::path out = Path("out");
  ASSERT_EQ(Run({"run", jobs_[0], "-o", out.string(), "-q"}, &err), 0) << err;
  Write(out / ".job" / "state.json.tmp-999996", "stale");
  Write(out / "graph.g2o.tmp-999995", "stale");
  Write(out / "trajectories" / "campus.tum.tmp-999994", "stale");
  Write(out / "mine.txt.tmp-999993", "not ours");
  ASSERT_EQ(Run({"run", jobs_[0], "-o", out.string(), "--resume", "-q"}, &err), 0) << err;
  EXPECT_FALSE(fs::exists(out / ".job" / "state.json.tmp-999996"));
  EXPECT_FALSE(fs::exists(out / "graph.g2o.tmp-999995"));
  EXPECT_FALSE(fs::exists(out / "trajectories" / "campus.tum.tmp-999994"));
  EXPECT_EQ(Read(out / "mine.txt.tmp-999993"), "not ours");

  // Plain outputs in a folder that is not ours: a temporary whose writer is
  // gone (no such pid, no lock on it) goes; a live process's stays.
  const fs::path plain = Path("plain");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  const std::string dead = std::to_string(child);
  const std::string alive = std::to_string(::getpid());
  Write(plain / ("c.json.tmp-" + dead), "stale");
  Write(plain / ("c.json.state.1.bin.tmp-" + dead), "stale");
  Write(plain / ("x.g2o.tmp-" + dead), "stale");
  Write(plain / ("x.g2o.tmp-" + alive), "live");
  ASSERT_EQ(Run({"solve", inputs_[0], "--checkpoint", (plain / "c.json").string(), "-o",
                 (plain / "x.g2o").string(), "-q"},
                &err) % 4,
            0)
      << err;
  EXPECT_FALSE(fs::exists(plain / ("c.json.tmp-" + dead)));
  EXPECT_FALSE(fs::exists(plain / ("c.json.state.1.bin.tmp-" + dead)));
  EXPECT_FALSE(fs::exists(plain / ("x.g2o.tmp-" + dead)));
  EXPECT_EQ(Read(plain / ("x.g2o.tmp-" + alive)), "live");
}

// `solve STORE --associate` exchanges STORE with its rewritten copy; from the
// exchange to the exit STORE stays locked (the rewrite's lock moved with the
// folder), so a second writer in that window is refused.
TEST_F(AdversarialStore, AssociateRewriteKeepsTheStoreLockedToTheExit) {
  const fs::path store = Path("store");
  Ingest(0, store);
  const pid_t pid = SpawnGraphslamRedirected({"solve", store.string(), "--associate", "-q"},
                                             Path("associate.txt").string(),
                                             {{"GRAPHSLAM_STOP_AT", "associate_exchanged"}});
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, WUNTRACED), pid);
  ASSERT_TRUE(WIFSTOPPED(status)) << "the solve ended before the exchange: "
                                  << Read(Path("associate.txt"));
  ASSERT_TRUE(fs::exists(store / "MANIFEST.json"));
  EXPECT_FALSE(fs::exists(store.string() + ".associating"));
  const std::map<std::string, std::string> rewritten = Snapshot(store);
  std::string err;
  const int ingest = Run({"ingest", inputs_[1], "-o", store.string(), "-q"}, &err);
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  EXPECT_EQ(ingest, 3) << err;
  EXPECT_THAT(err, HasSubstr(kLocked));
  EXPECT_THAT(err, HasSubstr("pid " + std::to_string(pid) + ")"));
  EXPECT_EQ(Snapshot(store), rewritten);
  EXPECT_EQ(Run({"solve", store.string(), "-q"}, &err) % 4, 0) << err;
}

}  // namespace
}  // namespace graphslam
