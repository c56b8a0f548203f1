// The memory budget of --memory-limit (tools/memory_budget.h): the budget
// arithmetic against its component sizes, and the commands (ingest, solve
// of a store, solve --workdir) refusing a limit below the need at the start,
// naming the need, and running within a feasible limit.
#include "tools/memory_budget.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <sys/resource.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "storage/chunk_store.h"
#include "storage/native_log_counts.h"
#include "tests/testing/subprocess.h"
#include "tests/tools/out_of_core_fixture.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

TEST(BudgetSolve, ChunksInFlightAndTheFactorGetWhatThePoseSystemLeaves) {
  const SolveSize size{1000, 100, 5000, 1024, /*streaming=*/true};
  const int64_t rest = kSolveBaseBytes + 1000 * kPoseSystemBytesPerPose +
                       100 * kBytesPerFeatureStreaming;
  const int64_t chunk = 1024 * kBytesPerObservationInFlight;
  // No limit: the default, nothing refused.
  EXPECT_EQ(BudgetSolve(0, size, 8)->chunks_in_flight, 8);
  EXPECT_EQ(BudgetSolve(0, size, 8)->need_bytes, rest + chunk);
  EXPECT_EQ(BudgetSolve(rest + chunk, size, 8)->chunks_in_flight, 1);
  EXPECT_EQ(BudgetSolve(rest + 3 * chunk + chunk - 1, size, 8)->chunks_in_flight, 3);
  EXPECT_EQ(BudgetSolve(rest + 3 * chunk + chunk - 1, size, 8)->factor_bytes, chunk - 1);
  const StatusOr<SolveBudget> large = BudgetSolve(rest + 100 * chunk, size, 8);
  EXPECT_EQ(large->chunks_in_flight, 8);
  EXPECT_EQ(large->factor_bytes, 92 * chunk);
  const StatusOr<SolveBudget> small = BudgetSolve(rest + chunk - 1, size, 8);
  ASSERT_FALSE(small.ok());
  EXPECT_EQ(small.status().code(), Status::Code::kInvalidArgument);
  EXPECT_NE(small.status().ToString().find(std::to_string(rest + chunk) + " bytes"),
            std::string::npos)
      << small.status().ToString();
}

// In memory the observations are loaded; a limit that only streaming fits is
// refused with the streaming need in the message.
TEST(BudgetSolve, InMemoryCountsTheObservationsAndNamesTheStreamingNeed) {
  SolveSize size{1000, 100000, 1000000, 4096, /*streaming=*/false};
  const int64_t chunk = 4096 * kBytesPerObservationInFlight;
  const int64_t in_memory = kSolveBaseBytes + 1000 * kPoseSystemBytesPerPose +
                            100000 * kBytesPerFeature + 1000000 * kBytesPerObservationInMemory +
                            chunk;
  const int64_t streaming = kSolveBaseBytes + 1000 * kPoseSystemBytesPerPose +
                            100000 * kBytesPerFeatureStreaming + chunk;
  EXPECT_EQ(BudgetSolve(0, size, 8)->need_bytes, in_memory);
  const StatusOr<SolveBudget> refused = BudgetSolve(streaming, size, 8);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("streaming mode (--streaming-poses 0) needs " +
                                             FormatBytes(streaming) + " and fits"),
            std::string::npos)
      << refused.status().ToString();
  size.streaming = true;
  EXPECT_EQ(BudgetSolve(streaming, size, 8)->chunks_in_flight, 1);
  // The streaming start's feature sample gets what one chunk in flight
  // leaves, at an in-memory observation's cost; no limit, no cap.
  EXPECT_EQ(BudgetSolve(streaming, size, 8)->sample_observations, 0);
  EXPECT_EQ(BudgetSolve(streaming + 1000 * kBytesPerObservationInMemory + 1, size, 8)
                ->sample_observations,
            1000);
  EXPECT_EQ(BudgetSolve(0, size, 8)->sample_observations, -1);
}

// The 10^8-feature store (10^6 poses, 4.375*10^7 observed features, chunks
// of 4096) fits 3 GiB streaming with all 8 chunks in flight.
TEST(BudgetSolve, TheHundredMillionFeatureStoreFitsThreeGib) {
  const StatusOr<SolveBudget> budget =
      BudgetSolve(int64_t{3} << 30, SolveSize{1000000, 43750683, 399899840, 4096, true}, 8);
  ASSERT_TRUE(budget.ok()) << budget.status().ToString();
  EXPECT_EQ(budget->chunks_in_flight, 8);
}

// Reading problem.graphslam comes before the passes: with many features per
// pose its per-feature arrays (kReadBytesPerFeature, the id with the
// estimate) outweigh the passes' (kBytesPerFeatureStreaming, ids parked),
// and the need is the read's, named in the refusal; with many poses per
// feature the passes' pose system is the larger.
TEST(BudgetSolve, TheNeedIsTheLargerOfTheReadAndThePasses) {
  const int64_t problem_bytes = int64_t{600} << 20;  // tokenizer blocks at their cap
  const SolveSize features{1000, 10000000, 40000000, 4096, true, problem_bytes};
  const int64_t read = kSolveBaseBytes + kReaderBlockBytes + 10000000 * kReadBytesPerFeature +
                       1000 * kReadBytesPerPose;
  const int64_t passes = kSolveBaseBytes + 1000 * kPoseSystemBytesPerPose +
                         10000000 * kBytesPerFeatureStreaming +
                         4096 * kBytesPerObservationInFlight;
  ASSERT_GT(read, passes);
  EXPECT_EQ(BudgetSolve(0, features, 8)->need_bytes, read);
  const StatusOr<SolveBudget> refused = BudgetSolve(read - 1, features, 8);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("reading the problem file"), std::string::npos)
      << refused.status().ToString();
  EXPECT_TRUE(BudgetSolve(read, features, 8).ok());

  const SolveSize poses{1000000, 1000000, 40000000, 4096, true, problem_bytes};
  EXPECT_EQ(BudgetSolve(0, poses, 8)->need_bytes,
            kSolveBaseBytes + 1000000 * kPoseSystemBytesPerPose +
                1000000 * kBytesPerFeatureStreaming + 4096 * kBytesPerObservationInFlight);
}

// The records are counted in 1 MiB reads: one split between two reads at
// any point of its keyword is counted once (a FEATURE split past its sixth
// byte was missed: the solve then refused the very need it had named).
TEST(CountPoseAndFeatureRecords, RecordsSplitBetweenReadsAreCountedOnce) {
  const fs::path path = fs::temp_directory_path() /
                        ("graphslam_count_records_" + std::to_string(::getpid()) + ".log");
  const size_t block = size_t{1} << 20;
  for (const std::string record : {"FEATURE", "POSE"}) {
    for (size_t split = 0; split <= 10; ++split) {
      SCOPED_TRACE(record + " split " + std::to_string(split));
      // The newline before the straddling record sits `split` bytes before
      // the end of the first read.
      std::string text = "GRAPHSLAM_LOG 1\nPOSE 0 0\nFEATURE 1\n#";
      text.append(block - split - text.size() - 1, 'x');
      text += "\n" + record + " 2\nPOSE 3 0\nFEATURE 4\n";
      std::ofstream(path, std::ios::binary) << text;
      const StatusOr<RecordCounts> counts = CountPoseAndFeatureRecords(path.string());
      ASSERT_TRUE(counts.ok()) << counts.status().ToString();
      EXPECT_EQ(counts->poses, record == "POSE" ? 3 : 2);
      EXPECT_EQ(counts->features, record == "FEATURE" ? 3 : 2);
    }
  }
  fs::remove(path);
}

// --solver cholmod: the factor (4 x its 8 lnz) must fit in what the chunks
// leave; else the refusal names the smallest limit whose budget holds it.
TEST(CheckCholmodFactor, TheFactorFitsWhatTheChunksLeaveOrTheSmallestLimitIsNamed) {
  const SolveSize size{1000, 100, 5000, 1024, /*streaming=*/true};
  const int64_t rest = kSolveBaseBytes + 1000 * kPoseSystemBytesPerPose +
                       100 * kBytesPerFeatureStreaming;
  const int64_t chunk = 1024 * kBytesPerObservationInFlight;
  // A small factor fits beside one chunk in flight.
  const double small_factor = 1000;
  EXPECT_TRUE(CheckCholmodFactor(rest + chunk + 4000, size, 8, small_factor).ok());
  const Status refused = CheckCholmodFactor(rest + chunk + 3999, size, 8, small_factor);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.code(), Status::Code::kInvalidArgument);
  EXPECT_NE(refused.ToString().find("needs a limit of at least " +
                                    FormatBytes(rest + chunk + 4000) + " (" +
                                    std::to_string(rest + chunk + 4000) + " bytes)"),
            std::string::npos)
      << refused.ToString();
  // A factor larger than a chunk: below 8 chunks in flight the limit's excess
  // over whole chunks is less than a chunk, so the smallest limit keeps 8.
  const double large_factor = 3.0 * chunk;
  const int64_t smallest = rest + 8 * chunk + 12 * chunk;
  EXPECT_TRUE(CheckCholmodFactor(smallest, size, 8, large_factor).ok());
  EXPECT_FALSE(CheckCholmodFactor(smallest - 1, size, 8, large_factor).ok());
  const Status named = CheckCholmodFactor(rest + 5 * chunk, size, 8, large_factor);
  ASSERT_FALSE(named.ok());
  // Not "(" + std::to_string(...): a GCC 12 -Wrestrict false positive.
  const std::string bytes = std::to_string(smallest).append(" bytes)");
  EXPECT_NE(named.ToString().find(bytes), std::string::npos) << named.ToString();
}

TEST(BudgetIngest, PassOneOrPassTwoWithOneChunkIsTheNeedAndTheBufferGetsTheRest) {
  IngestInput log;
  log.poses = 10000;
  log.features = 1000000;
  log.observations = 10000000;
  log.input_bytes = 1000;
  const int64_t fixed = kIngestBaseBytes + 250;
  EXPECT_EQ(log.FixedBytes(), fixed);
  // Not counted: the features at the unknown id range's figure.
  const int64_t pass1 =
      fixed + 10000 * kIngestBytesPerPose + 1000000 * kIngestPass1BytesPerFeatureUnknownIds;
  const int64_t pass2 =
      fixed + 10000 * kIngestBytesPerPose + 1000000 * kIngestPass2BytesPerFeature;
  ASSERT_GT(pass1, pass2 + 4096 * kIngestBytesPerBufferedObservation);
  EXPECT_EQ(BudgetIngest(0, log, 4096)->need_bytes, pass1);
  // At the need, the buffer is what pass 2 leaves; a larger limit gives a
  // larger buffer, up to the observations.
  const StatusOr<IngestBudget> at_need = BudgetIngest(pass1, log, 4096);
  ASSERT_TRUE(at_need.ok()) << at_need.status().ToString();
  EXPECT_EQ(at_need->buffer_observations, (pass1 - pass2) / kIngestBytesPerBufferedObservation);
  EXPECT_EQ(BudgetIngest(pass2 + 1000 * kIngestBytesPerBufferedObservation * 1000, log, 4096)
                ->buffer_observations,
            1000000);
  EXPECT_EQ(BudgetIngest(int64_t{1} << 40, log, 4096)->buffer_observations, 10000000);
  const StatusOr<IngestBudget> refused = BudgetIngest(pass1 - 1, log, 4096);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find(std::to_string(pass1) + " bytes"), std::string::npos)
      << refused.status().ToString();
  // Counted by a trailer with the id range: the reserved arrays per
  // feature plus the id table per id; without the range, as uncounted.
  log.counted = true;
  log.feature_id_end = 3000000;
  EXPECT_EQ(BudgetIngest(0, log, 4096)->need_bytes,
            fixed + 10000 * kIngestBytesPerPose + 1000000 * kIngestPass1BytesPerFeature +
                3000000 * kIngestBytesPerFeatureId);
  // Few ids per feature: the guesses held after the read, or pass 2 with
  // one chunk, are the larger part.
  log.feature_id_end = 1000000;
  ASSERT_LT(1000000 * kIngestPass1BytesPerFeature + 1000000 * kIngestBytesPerFeatureId,
            1000000 * kIngestHeldBytesPerFeature);
  EXPECT_EQ(BudgetIngest(0, log, 4096)->need_bytes,
            fixed + 10000 * kIngestBytesPerPose +
                std::max(1000000 * kIngestHeldBytesPerFeature,
                         1000000 * kIngestPass2BytesPerFeature +
                             4096 * kIngestBytesPerBufferedObservation));
  log.feature_id_end = 2500000;
  EXPECT_EQ(log.Expected().features, 1000000);
  EXPECT_EQ(log.Expected().feature_id_end, 2500000);
  log.feature_id_end = -1;
  EXPECT_EQ(BudgetIngest(0, log, 4096)->need_bytes, pass1);
  log.counted = false;
  EXPECT_EQ(log.Expected().features, 0);  // nothing reserved on an estimate
  // A log with few features: pass 2 with one chunk of buffer is the need.
  log.features = 10;
  EXPECT_EQ(BudgetIngest(0, log, 4096)->need_bytes,
            fixed + 10000 * kIngestBytesPerPose + 10 * kIngestPass2BytesPerFeature +
                4096 * kIngestBytesPerBufferedObservation);
}

TEST(EstimateIngestInput, ALogIsMeasuredByItsSizeAndOtherFormatsAreReadWhole) {
  const fs::path dir = fs::temp_directory_path() / ("graphslam_budget_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path log = dir / "log.graphslam";
  { std::ofstream(log) << std::string(6500000, '#'); }
  const StatusOr<IngestInput> native = EstimateIngestInput(log.string(), storage::InputFormat::kNative);
  ASSERT_TRUE(native.ok());
  EXPECT_TRUE(native->streamed);
  EXPECT_EQ(native->features, 6500000 / kLogBytesPerFeature);
  EXPECT_EQ(native->observations, 6500000 / kLogBytesPerObservation);
  const StatusOr<IngestInput> g2o = EstimateIngestInput(log.string(), storage::InputFormat::kG2o);
  EXPECT_FALSE(g2o->streamed);
  EXPECT_EQ(BudgetIngest(0, *g2o, 16)->need_bytes,
            kIngestBaseBytes + 6500000 / 4 + 6500000 * kReadWholeBytesPerInputByte +
                16 * kIngestBytesPerBufferedObservation);
  EXPECT_FALSE(native->counted);
  EXPECT_FALSE(EstimateIngestInput((dir / "missing").string(), storage::InputFormat::kNative).ok());
  // A log that ends with its counts trailer is budgeted on its counts.
  {
    std::ofstream(log, std::ios::app)
        << "\n" << storage::NativeLogCountsLine({1000, 20000, 300000});
  }
  const StatusOr<IngestInput> counted =
      EstimateIngestInput(log.string(), storage::InputFormat::kNative);
  ASSERT_TRUE(counted.ok());
  EXPECT_TRUE(counted->counted);
  EXPECT_EQ(counted->poses, 1000);
  EXPECT_EQ(counted->features, 20000);
  EXPECT_EQ(counted->observations, 300000);
  fs::remove_all(dir);
}

class MemoryLimitCommandTest : public graphslam::testing::OutOfCoreFixture {
 protected:
  // Runs the binary with stderr in a file; returns the exit code and the text.
  int Run(const std::vector<std::string>& args, std::string* err) {
    const std::string path = (dir_ / "stderr.txt").string();
    const int code = graphslam::testing::WaitForExit(
        graphslam::testing::SpawnGraphslamRedirected(args, path));
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    *err = text.str();
    return code;
  }
  // A simulated store in 1024-observation chunks, and the solve need the
  // refusal of a 1M limit names (the bytes after "need of ... (").
  int64_t StoreAndItsSolveNeed(const std::string& store) {
    std::string err;
    EXPECT_EQ(Run({"ingest", Simulate(600, 7), "-o", store, "--chunk-observations", "1024", "-q"},
                  &err),
              0)
        << err;
    EXPECT_NE(Run({"solve", store, "--memory-limit", "1M", "-q"}, &err), 0);
    const size_t open = err.find("need of ");
    if (open == std::string::npos) {
      ADD_FAILURE() << err;
      return 0;
    }
    return std::stoll(err.substr(err.find('(', open) + 1));
  }
};

// The simulator's log ends with its counts: the ingest's refusal says the
// budget was counted, with the log's exact poses and observed features.
TEST_F(MemoryLimitCommandTest, TheSimulatorsCountsTrailerSizesTheIngest) {
  const fs::path sim = dir_ / "streamed";
  ASSERT_EQ(graphslam::testing::RunGraphslam({"simulate", "-o", sim.string(), "--poses", "600",
                                              "--runs", "2", "--gps-every", "25", "--streaming",
                                              "--compress", "-q"}),
            0);
  const std::string input = (sim / "log.graphslam.zst").string();
  const StatusOr<storage::NativeLogCounts> counts = storage::ReadNativeLogCounts(input);
  ASSERT_TRUE(counts.ok()) << counts.status().ToString();
  EXPECT_EQ(counts->poses, 600);
  // Ids are feature_id_base (10^6) + the world's slot.
  EXPECT_GT(counts->feature_id_end, 1000000 + counts->features - 1);
  std::string err;
  EXPECT_EQ(Run({"ingest", input, "-o", (dir_ / "store").string(), "--memory-limit", "1M", "-q"},
                &err),
            2);
  EXPECT_NE(err.find("(600 poses, " + std::to_string(counts->features) +
                     " features, counted by the log's trailer)"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find(" (" + std::to_string(counts->feature_id_end) + " ids in the table)"),
            std::string::npos)
      << err;
  // The ingest reads the log, trailer and all, to the same counts.
  ASSERT_EQ(Run({"ingest", input, "-o", (dir_ / "store").string(), "-q"}, &err), 0) << err;
  const auto store = storage::DiskChunkSource::Open((dir_ / "store").string());
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  EXPECT_EQ((*store)->total_observations(), counts->observations);
}

// Each command refuses a limit below its need at the start, naming the need
// (the smallest limit that works): nothing is written.
TEST_F(MemoryLimitCommandTest, TooSmallLimitsAreRefusedNamingTheNeed) {
  const std::string input = Simulate(600, 7);
  const std::string store = (dir_ / "store").string();
  std::string err;
  EXPECT_NE(Run({"ingest", input, "-o", store, "--memory-limit", "8M", "-q"}, &err), 0);
  EXPECT_NE(err.find("--memory-limit 8.0 MiB is below the estimated need of"), std::string::npos)
      << err;
  EXPECT_NE(err.find("the smallest limit that works"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(fs::path(store) / "MANIFEST.json"));
  ASSERT_EQ(Run({"ingest", input, "-o", store, "--memory-limit", "512M", "-q"}, &err), 0) << err;
  EXPECT_NE(Run({"solve", store, "--memory-limit", "8M", "-q"}, &err), 0);
  EXPECT_NE(err.find("--memory-limit 8.0 MiB is below the estimated need of"), std::string::npos)
      << err;
  EXPECT_NE(Run({"solve", input, "--workdir", (dir_ / "w").string(), "--memory-limit", "8M",
                 "-q"},
                &err),
            0);
  EXPECT_NE(err.find("is below the estimated need of"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "w" / "MANIFEST.json"));
}

// --solver cholmod under a limit that leaves no room for its factor stops
// before factorizing, naming the smallest limit; at that limit it solves.
TEST_F(MemoryLimitCommandTest, CholmodIsRefusedWhenItsFactorDoesNotFitTheLimit) {
  const std::string store = (dir_ / "store").string();
  const int64_t need = StoreAndItsSolveNeed(store);
  ASSERT_GT(need, kSolveBaseBytes);
  std::string err;
  // At the need exactly, one chunk in flight and nothing left for a factor.
  const std::string out = (dir_ / "out.g2o").string();
  EXPECT_EQ(Run({"solve", store, "--solver", "cholmod", "--memory-limit", std::to_string(need),
                 "-o", out, "-q"},
                &err),
            2)
      << err;
  EXPECT_NE(err.find("does not hold --solver cholmod"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
  const size_t at = err.find("needs a limit of at least ");
  ASSERT_NE(at, std::string::npos) << err;
  const int64_t smallest = std::stoll(err.substr(err.find('(', at) + 1));
  EXPECT_GT(smallest, need);
  const std::string report = (dir_ / "r.json").string();
  const int code = Run({"solve", store, "--solver", "cholmod", "--memory-limit",
                        std::to_string(smallest), "--report", report, "--max-iterations", "5",
                        "-q"},
                       &err);
  ASSERT_TRUE(code == 0 || code == 4) << code << ": " << err;
  EXPECT_EQ(graphslam::testing::ReadJson(report)["solver"].get<std::string>(), "cholmod");
}

// The need the refusal names is a limit the solve then runs in: a store
// solved at exactly that limit succeeds, and its peak RSS (the report's
// getrusage figure) stays below the limit.
TEST_F(MemoryLimitCommandTest, TheNamedNeedIsALimitTheSolveRunsWithin) {
  const std::string store = (dir_ / "store").string();
  const int64_t need = StoreAndItsSolveNeed(store);
  ASSERT_GT(need, kSolveBaseBytes);
  std::string err;
  const std::string report = (dir_ / "r.json").string();
  // 0, or 4 (kExitNotConverged) when the 5 iterations do not converge.
  const int code = Run({"solve", store, "--memory-limit", std::to_string(need), "--report",
                        report, "--max-iterations", "5", "-q"},
                       &err);
  ASSERT_TRUE(code == 0 || code == 4) << code << ": " << err;
  const nlohmann::json r = graphslam::testing::ReadJson(report);
  EXPECT_GE(r["chunks_in_flight"].get<int>(), 1);
  EXPECT_LT(r["peak_rss_bytes"].get<int64_t>(), need);
}

}  // namespace
}  // namespace graphslam::tools
