#include "pipeline/history_store.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>

#include <sqlite3.h>

#include "pipeline/error.h"

namespace autocal {
namespace {

// "ACAL": marks the file as an autocal history in SQLite's header.
constexpr int kApplicationId = 0x4143414C;

const char* const kSchema = R"sql(
CREATE TABLE schema_version (version INTEGER NOT NULL);
CREATE TABLE session (key TEXT PRIMARY KEY, value REAL NOT NULL);
CREATE TABLE attempts (
  id INTEGER PRIMARY KEY, t_ns INTEGER NOT NULL, verdict TEXT NOT NULL, reason TEXT NOT NULL,
  regime_id INTEGER NOT NULL, usable INTEGER NOT NULL, solver_report TEXT NOT NULL,
  width INTEGER NOT NULL, height INTEGER NOT NULL,
  fx REAL, fy REAL, cx REAL, cy REAL, k1 REAL, k2 REAL, p1 REAL, p2 REAL, k3 REAL,
  covariance BLOB, free_parameters TEXT NOT NULL, rms_px REAL,
  material TEXT NOT NULL, frames INTEGER NOT NULL, planes INTEGER NOT NULL,
  points INTEGER NOT NULL, observations INTEGER NOT NULL, lines INTEGER NOT NULL,
  rotation_spread_deg REAL, max_sigma REAL,
  trend_fx REAL, trend_fy REAL, trend_cx REAL, trend_cy REAL, trend_k1 REAL, trend_k2 REAL,
  trend_p1 REAL, trend_p2 REAL, trend_k3 REAL,
  out_fx REAL, out_fy REAL, out_cx REAL, out_cy REAL, out_k1 REAL, out_k2 REAL,
  out_p1 REAL, out_p2 REAL, out_k3 REAL,
  out_sigma_fx REAL, out_sigma_fy REAL, out_sigma_cx REAL, out_sigma_cy REAL,
  out_sigma_k1 REAL, out_sigma_k2 REAL, out_sigma_p1 REAL, out_sigma_p2 REAL, out_sigma_k3 REAL);
CREATE TABLE alarms (
  id INTEGER PRIMARY KEY, t_ns INTEGER NOT NULL, kind TEXT NOT NULL,
  attempt_id INTEGER NOT NULL, description TEXT NOT NULL);
CREATE TABLE alarm_jumps (
  alarm_id INTEGER NOT NULL, quantity TEXT NOT NULL, size_px REAL NOT NULL,
  PRIMARY KEY (alarm_id, quantity));
CREATE TABLE regimes (
  id INTEGER PRIMARY KEY, start_ns INTEGER NOT NULL, confirmed_ns INTEGER NOT NULL,
  alarm_id INTEGER, founders TEXT NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  fx REAL, fy REAL, cx REAL, cy REAL, k1 REAL, k2 REAL, p1 REAL, p2 REAL, k3 REAL);
)sql";

// A prepared statement; binds and reads columns in order.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::string& path) : path_(path) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement_, nullptr) != SQLITE_OK) {
      const std::string message = sqlite3_errmsg(db);
      sqlite3_finalize(statement_);
      throw Error(path, 0, message);
    }
  }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& Bind(int64_t value) { return Check(sqlite3_bind_int64(statement_, ++bound_, value)); }
  Statement& Bind(int value) { return Bind(int64_t(value)); }
  // SQLite would store a NaN as NULL; Column() reads NULL back as NaN.
  Statement& Bind(double value) { return Check(sqlite3_bind_double(statement_, ++bound_, value)); }
  Statement& Bind(const std::string& text) {
    return Check(
        sqlite3_bind_text(statement_, ++bound_, text.data(), int(text.size()), SQLITE_TRANSIENT));
  }
  Statement& BindNull() { return Check(sqlite3_bind_null(statement_, ++bound_)); }
  Statement& BindBlob(const void* data, int bytes) {
    return Check(sqlite3_bind_blob(statement_, ++bound_, data, bytes, SQLITE_TRANSIENT));
  }

  // True while there is a row to read.
  bool Step() {
    column_ = 0;
    const int status = sqlite3_step(statement_);
    if (status == SQLITE_ROW) return true;
    if (status == SQLITE_DONE) return false;
    throw Error(path_, 0, sqlite3_errmsg(sqlite3_db_handle(statement_)));
  }
  // Makes it ready to run again with new bindings.
  void Reset() {
    sqlite3_reset(statement_);
    sqlite3_clear_bindings(statement_);
    bound_ = 0;
  }
  // Runs a statement that returns no rows.
  void Run() {
    Step();
    Reset();
  }

  int64_t Int() { return sqlite3_column_int64(statement_, column_++); }
  double Real() {
    const int column = column_++;
    if (sqlite3_column_type(statement_, column) == SQLITE_NULL) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    return sqlite3_column_double(statement_, column);
  }
  std::optional<int64_t> OptionalInt() {
    if (sqlite3_column_type(statement_, column_) == SQLITE_NULL) {
      ++column_;
      return std::nullopt;
    }
    return Int();
  }
  std::string Text() {
    const int column = column_++;
    const auto* text = sqlite3_column_text(statement_, column);
    return text ? std::string(reinterpret_cast<const char*>(text),
                              size_t(sqlite3_column_bytes(statement_, column)))
                : std::string();
  }
  std::vector<double> Doubles() {
    const int column = column_++;
    const void* blob = sqlite3_column_blob(statement_, column);
    std::vector<double> values(size_t(sqlite3_column_bytes(statement_, column)) / sizeof(double));
    if (blob && !values.empty()) std::memcpy(values.data(), blob, values.size() * sizeof(double));
    return values;
  }

 private:
  Statement& Check(int status) {
    if (status != SQLITE_OK) throw Error(path_, 0, sqlite3_errmsg(sqlite3_db_handle(statement_)));
    return *this;
  }

  std::string path_;
  sqlite3_stmt* statement_ = nullptr;
  int bound_ = 0;
  int column_ = 0;
};

void Execute(sqlite3* db, const std::string& sql, const std::string& path) {
  char* message = nullptr;
  if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string text = message ? message : sqlite3_errmsg(db);
    sqlite3_free(message);
    throw Error(path, 0, text);
  }
}

int64_t QueryInt(sqlite3* db, const std::string& sql, const std::string& path) {
  Statement query(db, sql, path);
  return query.Step() ? query.Int() : 0;
}

// Every acceptance option by name, for the session table.
template <typename Options, typename Visit>
void ForEachOption(Options& o, Visit visit) {
  visit("max_rms_px", o.max_rms_px);
  visit("max_sigma", o.max_sigma);
  visit("focal_floor_fraction", o.focal_floor_fraction);
  visit("principal_floor_px", o.principal_floor_px);
  visit("distortion_floor_px", o.distortion_floor_px);
  visit("distortion_radius_fraction", o.distortion_radius_fraction);
  visit("window_s", o.window_s);
  visit("max_order", o.max_order);
  visit("min_points_linear", o.min_points_linear);
  visit("min_points_quadratic", o.min_points_quadratic);
  visit("order_evidence_chi2", o.order_evidence_chi2);
  visit("max_extrapolation_s", o.max_extrapolation_s);
  visit("attempt_window_s", o.attempt_window_s);
  visit("alarm_after", o.alarm_after);
  visit("confirm_after", o.confirm_after);
}

template <typename Camera, typename Visit>
void ForEachIntrinsic(Camera& c, Visit visit) {
  visit("width", c.width);
  visit("height", c.height);
  visit("fx", c.fx);
  visit("fy", c.fy);
  visit("cx", c.cx);
  visit("cy", c.cy);
  visit("k1", c.k1);
  visit("k2", c.k2);
  visit("p1", c.p1);
  visit("p2", c.p2);
  visit("k3", c.k3);
}

void BindCamera(Statement* s, const CameraIntrinsics& camera) {
  s->Bind(camera.width).Bind(camera.height);
  for (double v : camera.Packed()) s->Bind(v);
}

CameraIntrinsics ReadCamera(Statement* s) {
  const int width = int(s->Int());
  const int height = int(s->Int());
  std::array<double, kNumIntrinsics> packed;
  for (double& v : packed) v = s->Real();
  return CameraIntrinsics::FromPacked(packed, width, height);
}

std::string JoinInts(const std::vector<int>& values) {
  std::string text;
  for (int v : values) text += (text.empty() ? "" : " ") + std::to_string(v);
  return text;
}

std::vector<int> SplitInts(const std::string& text, const std::string& path,
                           const std::string& what) {
  std::istringstream in(text);
  std::vector<int> values;
  int v;
  while (in >> v) values.push_back(v);
  if (!in.eof()) throw Error(path, 0, what + ": expected integers, got '" + text + "'");
  return values;
}

std::string ColumnList(const std::string& prefix) {
  std::string columns;
  for (int p = 0; p < kNumIntrinsics; ++p) columns += ", " + prefix + IntrinsicName(p);
  return columns;
}

const std::string kAttemptColumns =
    "id, t_ns, verdict, reason, regime_id, usable, solver_report, width, height" + ColumnList("") +
    ", covariance, free_parameters, rms_px, material, frames, planes, points, observations, "
    "lines, rotation_spread_deg, max_sigma" +
    ColumnList("trend_") + ColumnList("out_") + ColumnList("out_sigma_");
const std::string kRegimeColumns =
    "id, start_ns, confirmed_ns, alarm_id, founders, width, height" + ColumnList("");

std::string Placeholders(const std::string& columns) {
  std::string marks = "?";
  for (char c : columns) {
    if (c == ',') marks += ", ?";
  }
  return marks;
}

void InsertAttempt(sqlite3* db, const std::string& path, const AttemptRecord& a) {
  Statement s(db,
              "INSERT INTO attempts (" + kAttemptColumns + ") VALUES (" +
                  Placeholders(kAttemptColumns) + ")",
              path);
  s.Bind(a.id).Bind(a.t_ns).Bind(VerdictName(a.verdict)).Bind(a.reason).Bind(a.regime);
  s.Bind(int(a.usable)).Bind(a.solver_report);
  BindCamera(&s, a.estimate);
  // Row-major doubles in the machine's byte order, n x n for n free parameters.
  std::vector<double> covariance;
  for (Eigen::Index r = 0; r < a.covariance.rows(); ++r) {
    for (Eigen::Index c = 0; c < a.covariance.cols(); ++c) covariance.push_back(a.covariance(r, c));
  }
  if (covariance.empty()) {
    s.BindNull();
  } else {
    s.BindBlob(covariance.data(), int(covariance.size() * sizeof(double)));
  }
  std::string free;
  for (int p : a.free_parameters) free += (free.empty() ? "" : " ") + IntrinsicName(p);
  s.Bind(free).Bind(a.rms_px).Bind(a.material);
  s.Bind(a.frames).Bind(a.planes).Bind(a.points).Bind(a.observations).Bind(a.lines);
  s.Bind(a.rotation_spread_deg).Bind(a.max_sigma);
  for (const auto* values : {&a.trend, &a.output, &a.output_sigma}) {
    for (double v : *values) s.Bind(v);
  }
  s.Run();
}

// The pre-mission calibration and the options, from the session table.
StoredHistory ReadSession(sqlite3* db, const std::string& path) {
  StoredHistory stored;
  Statement session(db, "SELECT key, value FROM session", path);
  while (session.Step()) {
    const std::string key = session.Text();
    const double value = session.Real();
    const auto assign = [&](const std::string& prefix) {
      return [&, prefix](const char* name, auto& field) {
        if (key == prefix + name) field = std::remove_reference_t<decltype(field)>(value);
      };
    };
    ForEachIntrinsic(stored.premission, assign("premission."));
    ForEachOption(stored.options, assign("options."));
  }
  return stored;
}

}  // namespace

void HistoryStore::Closer::operator()(sqlite3* db) const { sqlite3_close_v2(db); }

HistoryStore::HistoryStore(const std::string& path, Mode mode) : path_(path) {
  if (mode == Mode::kOpenExisting && !std::filesystem::exists(path)) {
    throw Error(path, 0, "no such history file");
  }
  sqlite3* db = nullptr;
  const int flags = SQLITE_OPEN_READWRITE | (mode == Mode::kOpenOrCreate ? SQLITE_OPEN_CREATE : 0);
  const int status = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  db_.reset(db);
  if (status != SQLITE_OK) {
    throw Error(path, 0,
                std::string("cannot open a history database: ") +
                    (db ? sqlite3_errmsg(db) : sqlite3_errstr(status)));
  }
  sqlite3_busy_timeout(db, 5000);
  const auto not_history = [&](const std::string& why) {
    return Error(path, 0, "not an autocal calibration history database (" + why + ")");
  };

  int64_t application_id = 0, tables = 0;
  try {
    application_id = QueryInt(db, "PRAGMA application_id", path);
    tables = QueryInt(db, "SELECT count(*) FROM sqlite_master", path);
  } catch (const Error& e) {
    throw not_history(e.what_expected());  // Not SQLite at all, or damaged.
  }
  if (application_id != kApplicationId) {
    if (tables > 0) throw not_history("it holds other tables");
    if (mode == Mode::kOpenExisting) throw not_history("it is empty");
    // A new file. WAL must be set outside a transaction; it stays set in the file.
    Execute(db, "PRAGMA journal_mode = WAL", path);
    Execute(db,
            "BEGIN IMMEDIATE; " + std::string(kSchema) + "INSERT INTO schema_version VALUES (" +
                std::to_string(kHistorySchemaVersion) +
                "); PRAGMA application_id = " + std::to_string(kApplicationId) + "; COMMIT;",
            path);
  }
  int64_t version = 0;
  try {
    version = QueryInt(db, "SELECT max(version) FROM schema_version", path);
  } catch (const Error&) {
    throw not_history("no schema_version table");
  }
  if (version > kHistorySchemaVersion) {
    throw Error(path, 0,
                "history schema version " + std::to_string(version) +
                    " is newer than this build of autocal reads (" +
                    std::to_string(kHistorySchemaVersion) + "); use a newer autocal");
  }
  if (version < 1) throw not_history("no schema version");
  Execute(db, "PRAGMA journal_mode = WAL; PRAGMA synchronous = FULL", path);
}

HistoryStore::~HistoryStore() = default;
HistoryStore::HistoryStore(HistoryStore&&) noexcept = default;
HistoryStore& HistoryStore::operator=(HistoryStore&&) noexcept = default;

HistoryRows RowsSince(const CalibrationHistory& history, size_t attempt, size_t alarm,
                      size_t regime) {
  const auto since = [](const auto& rows, size_t first) {
    using Rows = std::decay_t<decltype(rows)>;
    return first < rows.size() ? Rows(rows.begin() + ptrdiff_t(first), rows.end()) : Rows();
  };
  return {history.premission(),
          history.options(),
          attempt,
          alarm,
          regime,
          since(history.attempts(), attempt),
          since(history.alarms(), alarm),
          since(history.regimes(), regime)};
}

void HistoryStore::Record(const CalibrationHistory& history) {
  Append(history.premission(), history.options(), history.attempts(), 0, history.alarms(), 0,
         history.regimes(), 0);
}

void HistoryStore::Record(const HistoryRows& rows) {
  Append(rows.premission, rows.options, rows.attempts, rows.first_attempt, rows.alarms,
         rows.first_alarm, rows.regimes, rows.first_regime);
}

void HistoryStore::Append(const CameraIntrinsics& premission, const AcceptanceOptions& options,
                          std::span<const AttemptRecord> attempts, size_t first_attempt,
                          std::span<const Alarm> alarms, size_t first_alarm,
                          std::span<const Regime> regimes, size_t first_regime) {
  sqlite3* db = db_.get();
  Execute(db, "BEGIN IMMEDIATE", path_);
  try {
    const auto different = [&](const std::string& why) {
      return Error(path_, 0, "holds a different calibration history: " + why);
    };
    // How many of `table`'s rows the file holds, which must be at least those before
    // `first` and at most those up to the end of `rows`.
    const auto held = [&](const char* table, size_t first, size_t rows) {
      const auto count =
          size_t(QueryInt(db, std::string("SELECT count(*) FROM ") + table, path_));
      if (count > first + rows) throw different("it has more rows than this history");
      if (count < first) {
        throw Error(path_, 0,
                    "lacks rows of this history: it holds " + std::to_string(count) + " " +
                        table + ", the rows to append begin at " + std::to_string(first));
      }
      return count - first;
    };
    const size_t attempts_held = held("attempts", first_attempt, attempts.size());
    const size_t alarms_held = held("alarms", first_alarm, alarms.size());
    const size_t regimes_held = held("regimes", first_regime, regimes.size());
    if (QueryInt(db, "SELECT count(*) FROM session", path_) == 0) {
      Statement insert(db, "INSERT INTO session (key, value) VALUES (?, ?)", path_);
      ForEachIntrinsic(premission, [&](const char* name, auto value) {
        insert.Bind(std::string("premission.") + name).Bind(double(value)).Run();
      });
      ForEachOption(options, [&](const char* name, auto value) {
        insert.Bind(std::string("options.") + name).Bind(double(value)).Run();
      });
    } else if (!(ReadSession(db, path_).premission == premission)) {
      throw different("another pre-mission calibration");
    }
    if (attempts_held > 0 &&
        QueryInt(db,
                 "SELECT t_ns FROM attempts WHERE id = " +
                     std::to_string(first_attempt + attempts_held - 1),
                 path_) != attempts[attempts_held - 1].t_ns) {
      throw different("its last attempt is not this history's");
    }

    for (const Regime& r : regimes.subspan(regimes_held)) {
      Statement s(db,
                  "INSERT INTO regimes (" + kRegimeColumns + ") VALUES (" +
                      Placeholders(kRegimeColumns) + ")",
                  path_);
      s.Bind(r.id).Bind(r.start_ns).Bind(r.confirmed_ns);
      if (r.alarm < 0) {
        s.BindNull();
      } else {
        s.Bind(r.alarm);
      }
      s.Bind(JoinInts(r.founders));
      BindCamera(&s, r.start);
      s.Run();
    }
    for (const AttemptRecord& a : attempts.subspan(attempts_held)) InsertAttempt(db, path_, a);
    for (const Alarm& a : alarms.subspan(alarms_held)) {
      Statement s(db,
                  "INSERT INTO alarms (id, t_ns, kind, attempt_id, description) "
                  "VALUES (?, ?, ?, ?, ?)",
                  path_);
      s.Bind(a.id).Bind(a.t_ns).Bind(a.kind).Bind(a.attempt).Bind(a.description).Run();
      Statement jump(db, "INSERT INTO alarm_jumps (alarm_id, quantity, size_px) VALUES (?, ?, ?)",
                     path_);
      for (const JumpSize& j : a.jumped) jump.Bind(a.id).Bind(j.quantity).Bind(j.size_px).Run();
    }
    Execute(db, "COMMIT", path_);
  } catch (...) {
    sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

StoredHistory HistoryStore::Load() const {
  sqlite3* db = db_.get();
  StoredHistory stored = ReadSession(db, path_);

  Statement attempts(db, "SELECT " + kAttemptColumns + " FROM attempts ORDER BY id", path_);
  while (attempts.Step()) {
    AttemptRecord a;
    a.id = int(attempts.Int());
    const std::string where = "attempt " + std::to_string(a.id);
    a.t_ns = attempts.Int();
    const std::string verdict = attempts.Text();
    if (const auto v = VerdictFromName(verdict)) {
      a.verdict = *v;
    } else {
      throw Error(path_, 0, where + ": unknown verdict '" + verdict + "'");
    }
    a.reason = attempts.Text();
    a.regime = int(attempts.Int());
    a.usable = attempts.Int() != 0;
    a.solver_report = attempts.Text();
    a.estimate = ReadCamera(&attempts);
    const std::vector<double> covariance = attempts.Doubles();
    std::istringstream free(attempts.Text());
    for (std::string name; free >> name;) {
      const auto p = IntrinsicFromName(name);
      if (!p) throw Error(path_, 0, where + ": unknown free parameter '" + name + "'");
      a.free_parameters.push_back(*p);
    }
    const size_t n = a.free_parameters.size();
    if (covariance.size() != n * n) {
      throw Error(path_, 0,
                  where + ": covariance holds " + std::to_string(covariance.size()) +
                      " values for " + std::to_string(n) + " free parameters");
    }
    a.covariance.resize(Eigen::Index(n), Eigen::Index(n));
    for (size_t k = 0; k < covariance.size(); ++k)
      a.covariance(Eigen::Index(k / n), Eigen::Index(k % n)) = covariance[k];
    a.rms_px = attempts.Real();
    a.material = attempts.Text();
    a.frames = int(attempts.Int());
    a.planes = int(attempts.Int());
    a.points = int(attempts.Int());
    a.observations = int(attempts.Int());
    a.lines = int(attempts.Int());
    a.rotation_spread_deg = attempts.Real();
    a.max_sigma = attempts.Real();
    for (auto* values : {&a.trend, &a.output, &a.output_sigma}) {
      for (double& v : *values) v = attempts.Real();
    }
    stored.attempts.push_back(std::move(a));
  }

  Statement alarms(db, "SELECT id, t_ns, kind, attempt_id, description FROM alarms ORDER BY id",
                   path_);
  Statement jumps(db, "SELECT quantity, size_px FROM alarm_jumps WHERE alarm_id = ? ORDER BY rowid",
                  path_);
  while (alarms.Step()) {
    Alarm a;
    a.id = int(alarms.Int());
    a.t_ns = alarms.Int();
    a.kind = alarms.Text();
    a.attempt = int(alarms.Int());
    a.description = alarms.Text();
    jumps.Bind(a.id);
    while (jumps.Step()) {
      JumpSize j;
      j.quantity = jumps.Text();
      j.size_px = jumps.Real();
      a.jumped.push_back(j);
    }
    jumps.Reset();
    stored.alarms.push_back(std::move(a));
  }

  Statement regimes(db, "SELECT " + kRegimeColumns + " FROM regimes ORDER BY id", path_);
  while (regimes.Step()) {
    Regime r;
    r.id = int(regimes.Int());
    r.start_ns = regimes.Int();
    r.confirmed_ns = regimes.Int();
    r.alarm = int(regimes.OptionalInt().value_or(-1));
    r.founders = SplitInts(regimes.Text(), path_, "regime " + std::to_string(r.id) + " founders");
    r.start = ReadCamera(&regimes);
    stored.regimes.push_back(std::move(r));
  }
  return stored;
}

}  // namespace autocal
