#include "pipeline/history_store.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <future>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "devices/history_writer.h"
#include "pipeline/error.h"
#include "tests/test_util.h"

namespace autocal {
namespace {

constexpr int64_t kSecond = 1'000'000'000;

// A history with every verdict in it: steady attempts, a no-update, a fogged one (high
// RMS), one with a non-finite estimate, then a knock (alarm, new regime). Deterministic,
// so two processes build the same one.
class StreamMaker {
 public:
  StreamMaker() : random_(3) {}

  SelfCalibrationResult Next(int s) {
    CameraIntrinsics truth = test::SonnarLikeCamera();
    if (s >= 20) {
      truth.fx *= 0.98;
      truth.fy *= 0.98;
      truth.cx += 5.0;
    }
    SelfCalibrationResult r;
    if (s == 5) {
      r.reason = "no update: insufficient rotation (1.2 deg, 8.0 needed)";
      r.estimate = truth;
      return r;
    }
    std::normal_distribution<double> normal;
    r.usable = true;
    r.estimate = truth;
    r.estimate.fx += 0.8 * normal(random_);
    r.estimate.fy += 0.8 * normal(random_);
    r.estimate.cx += normal(random_);
    r.estimate.cy += normal(random_);
    r.estimate.k1 += 0.003 * normal(random_);
    r.estimate.k2 += 0.003 * normal(random_);
    r.free_parameters = {kFx, kFy, kCx, kCy, kK1, kK2};
    r.covariance = Eigen::MatrixXd::Identity(6, 6);
    r.covariance.diagonal() << 0.64, 0.64, 1.0, 1.0, 9e-6, 9e-6;
    r.covariance(0, 1) = r.covariance(1, 0) = 0.5;
    r.rms_px = s == 8 ? 2.7 : 0.35 + 0.01 * s;
    if (s == 9) r.estimate.k1 = std::numeric_limits<double>::quiet_NaN();
    if (s == 12) {  // Box 10 freed the tangential terms and k3 this time.
      r.free_parameters = {kFx, kFy, kCx, kCy, kK1, kK2, kP1, kP2, kK3};
      r.covariance = Eigen::MatrixXd::Identity(9, 9) * 1e-6;
      r.covariance.topLeftCorner(4, 4) = Eigen::Matrix4d::Identity();
    }
    r.reason = "fx " + std::to_string(r.estimate.fx);
    r.frames_used = 10 + s;
    r.planes_used = 1 + s % 3;
    r.points_used = 100 + s;
    r.observations_used = 1000 + 7 * s;
    r.lines_used = s % 5;
    r.rotation_spread_deg = 12.5 + 0.25 * s;
    return r;
  }

 private:
  std::mt19937 random_;
};

AcceptanceOptions UnusualOptions() {
  AcceptanceOptions o;
  o.max_rms_px = 1.25;
  o.max_sigma = 4.5;
  o.focal_floor_fraction = 0.0025;
  o.principal_floor_px = 1.1;
  o.distortion_floor_px = 0.6;
  o.distortion_radius_fraction = 0.75;
  o.window_s = 45.0;
  o.max_order = 1;
  o.min_points_linear = 4;
  o.min_points_quadratic = 7;
  o.order_evidence_chi2 = 8.0;
  o.max_extrapolation_s = 12.0;
  o.alarm_after = 2;
  o.confirm_after = 4;
  return o;
}

void ExpectSameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  const auto pa = a.Packed(), pb = b.Packed();
  for (int p = 0; p < kNumIntrinsics; ++p) {
    if (std::isnan(pa[p])) {
      EXPECT_TRUE(std::isnan(pb[p])) << IntrinsicName(p);
    } else {
      EXPECT_EQ(pa[p], pb[p]) << IntrinsicName(p);
    }
  }
}

void ExpectSameHistory(const CalibrationHistory& h, const StoredHistory& s) {
  EXPECT_EQ(s.premission, h.premission());
  const AcceptanceOptions& o = h.options();
  EXPECT_EQ(s.options.max_rms_px, o.max_rms_px);
  EXPECT_EQ(s.options.max_sigma, o.max_sigma);
  EXPECT_EQ(s.options.focal_floor_fraction, o.focal_floor_fraction);
  EXPECT_EQ(s.options.principal_floor_px, o.principal_floor_px);
  EXPECT_EQ(s.options.distortion_floor_px, o.distortion_floor_px);
  EXPECT_EQ(s.options.distortion_radius_fraction, o.distortion_radius_fraction);
  EXPECT_EQ(s.options.window_s, o.window_s);
  EXPECT_EQ(s.options.max_order, o.max_order);
  EXPECT_EQ(s.options.min_points_linear, o.min_points_linear);
  EXPECT_EQ(s.options.min_points_quadratic, o.min_points_quadratic);
  EXPECT_EQ(s.options.order_evidence_chi2, o.order_evidence_chi2);
  EXPECT_EQ(s.options.max_extrapolation_s, o.max_extrapolation_s);
  EXPECT_EQ(s.options.alarm_after, o.alarm_after);
  EXPECT_EQ(s.options.confirm_after, o.confirm_after);

  ASSERT_EQ(s.attempts.size(), h.attempts().size());
  for (size_t i = 0; i < s.attempts.size(); ++i) {
    const AttemptRecord& a = h.attempts()[i];
    const AttemptRecord& b = s.attempts[i];
    SCOPED_TRACE("attempt " + std::to_string(i));
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.t_ns, a.t_ns);
    EXPECT_EQ(b.verdict, a.verdict);
    EXPECT_EQ(b.reason, a.reason);
    EXPECT_EQ(b.regime, a.regime);
    EXPECT_EQ(b.usable, a.usable);
    EXPECT_EQ(b.solver_report, a.solver_report);
    ExpectSameCamera(a.estimate, b.estimate);
    EXPECT_EQ(b.free_parameters, a.free_parameters);
    ASSERT_EQ(b.covariance.rows(), a.covariance.rows());
    ASSERT_EQ(b.covariance.cols(), a.covariance.cols());
    EXPECT_TRUE(b.covariance == a.covariance);
    EXPECT_EQ(b.rms_px, a.rms_px);
    EXPECT_EQ(b.material, a.material);
    EXPECT_EQ(b.frames, a.frames);
    EXPECT_EQ(b.planes, a.planes);
    EXPECT_EQ(b.points, a.points);
    EXPECT_EQ(b.observations, a.observations);
    EXPECT_EQ(b.lines, a.lines);
    EXPECT_EQ(b.rotation_spread_deg, a.rotation_spread_deg);
    EXPECT_EQ(b.max_sigma, a.max_sigma);
    EXPECT_EQ(b.trend, a.trend);
    EXPECT_EQ(b.output, a.output);
    EXPECT_EQ(b.output_sigma, a.output_sigma);
  }
  ASSERT_EQ(s.alarms.size(), h.alarms().size());
  for (size_t i = 0; i < s.alarms.size(); ++i) {
    const Alarm& a = h.alarms()[i];
    const Alarm& b = s.alarms[i];
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.t_ns, a.t_ns);
    EXPECT_EQ(b.kind, a.kind);
    EXPECT_EQ(b.attempt, a.attempt);
    EXPECT_EQ(b.description, a.description);
    ASSERT_EQ(b.jumped.size(), a.jumped.size());
    for (size_t j = 0; j < a.jumped.size(); ++j) {
      EXPECT_EQ(b.jumped[j].quantity, a.jumped[j].quantity);
      EXPECT_EQ(b.jumped[j].size_px, a.jumped[j].size_px);
    }
  }
  ASSERT_EQ(s.regimes.size(), h.regimes().size());
  for (size_t i = 0; i < s.regimes.size(); ++i) {
    const Regime& a = h.regimes()[i];
    const Regime& b = s.regimes[i];
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.start_ns, a.start_ns);
    EXPECT_EQ(b.confirmed_ns, a.confirmed_ns);
    EXPECT_EQ(b.alarm, a.alarm);
    EXPECT_EQ(b.founders, a.founders);
    ExpectSameCamera(a.start, b.start);
  }
}

void RunSql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* message = nullptr;
  const int status = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  EXPECT_EQ(status, SQLITE_OK) << (message ? message : "");
  sqlite3_free(message);
  sqlite3_close(db);
}

std::string QueryText(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  sqlite3_open(path.c_str(), &db);
  sqlite3_stmt* statement = nullptr;
  std::string text;
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement, nullptr) == SQLITE_OK &&
      sqlite3_step(statement) == SQLITE_ROW) {
    text = reinterpret_cast<const char*>(sqlite3_column_text(statement, 0));
  }
  sqlite3_finalize(statement);
  sqlite3_close(db);
  return text;
}

// Expects opening `path` to throw an Error that names the file and says `what`.
void ExpectRejected(const std::string& path, const std::string& what,
                    HistoryStore::Mode mode = HistoryStore::Mode::kOpenOrCreate) {
  try {
    HistoryStore store(path, mode);
    ADD_FAILURE() << path << " was opened";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(HistoryStoreTest, EveryFieldSurvivesReopening) {
  const test::TempDir dir;
  const std::string path = dir / "history.db";
  CalibrationHistory history(test::SonnarLikeCamera(), UnusualOptions());
  StreamMaker stream;
  {
    HistoryStore store(path);
    for (int s = 1; s <= 20; ++s) {
      history.Judge(s * kSecond, stream.Next(s));
      store.Record(history);
    }
  }
  {  // Reopened by a new writer, which goes on appending.
    HistoryStore store(path);
    for (int s = 21; s <= 40; ++s) {
      history.Judge(s * kSecond, stream.Next(s));
      store.Record(history);
    }
  }
  for (Verdict v : {Verdict::kAccepted, Verdict::kRejected, Verdict::kNoUpdate, Verdict::kAlarm,
                    Verdict::kNewRegime}) {
    EXPECT_GE(history.Count(v), 1) << "the stream has a " << VerdictName(v);
  }
  ASSERT_EQ(history.regimes().size(), 2u);
  ExpectSameHistory(history, HistoryStore(path, HistoryStore::Mode::kOpenExisting).Load());
  EXPECT_EQ(QueryText(path, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(QueryText(path, "SELECT verdict FROM attempts WHERE id = 4"), "no update")
      << "readable with any SQLite tool";
}

TEST(HistoryStoreTest, KilledWriterKeepsCommittedRows) {
  const test::TempDir dir;
  const std::string path = dir / "killed.db";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The writer dies without closing anything, right after its 25th commit (or at its
    // first failure, which the parent then sees as missing rows).
    try {
      CalibrationHistory history(test::SonnarLikeCamera(), UnusualOptions());
      StreamMaker stream;
      HistoryStore store(path);
      for (int s = 1; s <= 25; ++s) {
        history.Judge(s * kSecond, stream.Next(s));
        store.Record(history);
      }
    } catch (...) {
    }
    kill(getpid(), SIGKILL);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;

  CalibrationHistory expected(test::SonnarLikeCamera(), UnusualOptions());
  StreamMaker stream;
  for (int s = 1; s <= 25; ++s) expected.Judge(s * kSecond, stream.Next(s));
  ExpectSameHistory(expected, HistoryStore(path, HistoryStore::Mode::kOpenExisting).Load());
}

TEST(HistoryStoreTest, ForeignAndNewerFilesAreRejectedByName) {
  const test::TempDir dir;
  const std::string text = dir / "notes.db";
  test::WriteTextFile(text, std::string(4096, 'x'));
  ExpectRejected(text, "not an autocal calibration history database");

  const std::string foreign = dir / "foreign.db";
  RunSql(foreign, "CREATE TABLE songs (title TEXT); INSERT INTO songs VALUES ('la');");
  ExpectRejected(foreign, "not an autocal calibration history database");

  const std::string newer = dir / "newer.db";
  { HistoryStore store(newer); }
  RunSql(newer, "UPDATE schema_version SET version = " + std::to_string(kHistorySchemaVersion + 1));
  ExpectRejected(newer, "newer");

  const std::string damaged = dir / "damaged.db";
  { HistoryStore store(damaged); }
  RunSql(damaged, "DROP TABLE schema_version");
  ExpectRejected(damaged, "no schema_version table");

  ExpectRejected(dir / "missing.db", "no such history file", HistoryStore::Mode::kOpenExisting);
  ExpectRejected(dir / "no/such/folder/history.db", "cannot open");
}

TEST(HistoryStoreTest, AnotherHistoryIsNotAppended) {
  const test::TempDir dir;
  const std::string path = dir / "history.db";
  StreamMaker stream;
  CalibrationHistory first(test::SonnarLikeCamera());
  HistoryStore store(path);
  for (int s = 1; s <= 3; ++s) {
    first.Judge(s * kSecond, stream.Next(s));
    store.Record(first);
  }
  CalibrationHistory other_lens(test::SonnarLikeCamera(-0.2, 0.05));
  other_lens.Judge(kSecond, stream.Next(4));
  EXPECT_THROW(store.Record(other_lens), Error);
  CalibrationHistory later(test::SonnarLikeCamera());
  for (int s = 1; s <= 4; ++s) later.Judge((s + 100) * kSecond, stream.Next(s));
  EXPECT_THROW(store.Record(later), Error) << "same lens, other attempts";
  EXPECT_EQ(store.Load().attempts.size(), 3u) << "nothing of them was written";
}

// Parts of a history, each from the last attempt of the part before (as HistoryWriter hands
// them over), make up the history; a part that does not join the file's rows is refused.
TEST(HistoryStoreTest, PartsRecordedInTurnMakeUpTheHistory) {
  const test::TempDir dir;
  const std::string path = dir / "history.db";
  CalibrationHistory history(test::SonnarLikeCamera(), UnusualOptions());
  StreamMaker stream;
  HistoryStore store(path);
  size_t attempts = 0, alarms = 0, regimes = 0;
  for (int s = 1; s <= 40; ++s) {
    history.Judge(s * kSecond, stream.Next(s));
    if (s % 3 != 0 && s != 40) continue;
    store.Record(RowsSince(history, attempts > 0 ? attempts - 1 : 0, alarms, regimes));
    attempts = history.attempts().size();
    alarms = history.alarms().size();
    regimes = history.regimes().size();
  }
  ASSERT_EQ(history.regimes().size(), 2u);
  ASSERT_FALSE(history.alarms().empty());
  ExpectSameHistory(history, store.Load());

  const std::string gap = dir / "gap.db";
  HistoryStore gapped(gap);
  try {
    gapped.Record(RowsSince(history, 5, 0, 0));
    ADD_FAILURE() << "a part beginning at attempt 5 was appended to an empty file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lacks rows"), std::string::npos) << e.what();
  }
  gapped.Record(RowsSince(history, 0, 0, 0));
  CalibrationHistory other(test::SonnarLikeCamera(), UnusualOptions());
  for (int s = 1; s <= 41; ++s) other.Judge((s + 100) * kSecond, stream.Next(s));
  EXPECT_THROW(gapped.Record(RowsSince(other, 39, 0, 0)), Error)
      << "its attempt 39 is not the file's";
  EXPECT_EQ(gapped.Load().attempts.size(), 40u);
}

// Submit hands rows over without waiting for the disk: with the file locked by another
// connection every submit returns, and the rows land once the lock is let go. (Were
// Submit to write, it would wait the store's 5 s busy timeout and throw.)
TEST(HistoryWriterTest, SubmitNeverWaitsForTheFile) {
  const test::TempDir dir;
  const std::string path = dir / "history.db";
  auto store = std::make_unique<HistoryStore>(path);
  std::atomic<int> commits{0};
  HistoryWriter writer(std::move(store), [&] { ++commits; });
  std::promise<void> release;
  test::HoldSqliteWriteLock(path, release.get_future().share()).wait();

  CalibrationHistory history(test::SonnarLikeCamera(), UnusualOptions());
  StreamMaker stream;
  for (int s = 1; s <= 40; ++s) {
    history.Judge(s * kSecond, stream.Next(s));
    writer.Submit(history);
  }
  EXPECT_EQ(commits, 0) << "nothing could be committed while the lock was held";
  release.set_value();
  writer.Finish();
  EXPECT_GE(commits, 1);
  EXPECT_LE(commits, 2) << "what came while a commit waited goes into the next";
  ExpectSameHistory(history, HistoryStore(path, HistoryStore::Mode::kOpenExisting).Load());
}

// A write that fails (here another program changed the file) is reported by the next
// Submit or Finish, and nothing is written after it.
TEST(HistoryWriterTest, AFailedWriteIsReportedAndStopsTheWriting) {
  const test::TempDir dir;
  const std::string path = dir / "history.db";
  HistoryWriter writer(std::make_unique<HistoryStore>(path));
  CalibrationHistory history(test::SonnarLikeCamera(), UnusualOptions());
  StreamMaker stream;
  for (int s = 1; s <= 3; ++s) {
    history.Judge(s * kSecond, stream.Next(s));
    writer.Submit(history);
  }
  writer.Finish();
  // Another program changes the file's last attempt: the next part no longer joins it.
  RunSql(path, "UPDATE attempts SET t_ns = t_ns + 1 WHERE id = 2");
  history.Judge(4 * kSecond, stream.Next(4));
  writer.Submit(history);
  try {
    writer.Finish();
    ADD_FAILURE() << "the file's changed attempt 2 went unnoticed";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find("different calibration history"), std::string::npos)
        << e.what();
  }
  history.Judge(5 * kSecond, stream.Next(5));
  EXPECT_THROW(writer.Submit(history), Error);
  EXPECT_EQ(HistoryStore(path).Load().attempts.size(), 3u) << "nothing written after the failure";
}

}  // namespace
}  // namespace autocal
