// Scenario files (YAML read with cv::FileStorage) and the text overrides of the CLI.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include <opencv2/core.hpp>

#include "devices/sim/simulator.h"
#include "pipeline/error.h"
#include "resources/builtin_scenarios.h"

namespace autocal {
namespace {

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const size_t end = s.find_last_not_of(" \t\r\n");
  return s.substr(begin, end - begin + 1);
}

// Parses "12.5" (seconds) or "50%" (fraction of the duration).
bool ParseTime(const std::string& text, ScenarioTime* time) {
  std::string t = Trim(text);
  const bool percent = !t.empty() && t.back() == '%';
  if (percent) t.pop_back();
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(t, &used);
  } catch (const std::exception&) {
    return false;
  }
  if (used != t.size() || !std::isfinite(value)) return false;
  *time = percent ? ScenarioTime{value / 100.0, true} : ScenarioTime{value, false};
  return true;
}

bool ParseNumber(const std::string& text, double* value) {
  const std::string t = Trim(text);
  size_t used = 0;
  try {
    *value = std::stod(t, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == t.size() && std::isfinite(*value);
}

bool ParseInt(const std::string& text, long long* value) {
  const std::string t = Trim(text);
  size_t used = 0;
  try {
    *value = std::stoll(t, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == t.size();
}

bool ParseResolution(const std::string& text, int* width, int* height) {
  std::smatch match;
  const std::string t = Trim(text);
  static const std::regex kPattern(R"((\d{1,5})\s*[xX]\s*(\d{1,5}))");
  if (!std::regex_match(t, match, kPattern)) return false;
  *width = std::stoi(match[1]);
  *height = std::stoi(match[2]);
  return true;
}

// Reads one scenario file, naming the file, the line where it can and the field in every
// complaint.
class ScenarioReader {
 public:
  ScenarioReader(std::string file, const std::string& text) : file_(std::move(file)) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) lines_.push_back(line);
  }

  [[noreturn]] void Fail(const std::string& field, const std::string& what) const {
    throw Error(file_, LineOf(field), field + ": " + what);
  }

  void Read(const cv::FileNode& root, Scenario* s) const {
    if (!root.isMap()) Fail("(top level)", "expected a map of fields");
    Keys(root, "",
         {"name", "description", "scene", "lens", "resolution", "fps", "seconds", "seed", "motion",
          "accelerometer", "image", "checkerboard", "intrinsics_events", "disturbances", "people",
          "surface_texture"});
    if (!root["name"].empty()) s->name = String(root["name"], "name");
    if (!root["description"].empty()) s->description = String(root["description"], "description");
    if (!root["scene"].empty()) s->scene = String(root["scene"], "scene");
    if (!root["lens"].empty()) s->lens = String(root["lens"], "lens");
    if (!root["resolution"].empty()) Resolution(root["resolution"], s);
    if (!root["fps"].empty()) s->fps = Number(root["fps"], "fps");
    if (!root["seconds"].empty()) s->seconds = Number(root["seconds"], "seconds");
    if (!root["seed"].empty()) {
      const int seed = Integer(root["seed"], "seed");
      if (seed < 0) Fail("seed", "expected a non-negative integer");
      s->seed = static_cast<uint32_t>(seed);
    }
    if (!root["motion"].empty()) Motion(root["motion"], &s->motion);
    if (!root["accelerometer"].empty()) Accelerometer(root["accelerometer"], &s->accelerometer);
    if (!root["image"].empty()) Image(root["image"], &s->image);
    if (!root["checkerboard"].empty()) Checkerboard(root["checkerboard"], &s->checkerboard);
    if (!root["intrinsics_events"].empty()) {
      s->intrinsics_events =
          List<IntrinsicsEvent>(root["intrinsics_events"], "intrinsics_events",
                                [this](auto& n, auto& f, auto* e) { Event(n, f, e); });
    }
    if (!root["disturbances"].empty()) {
      s->disturbances = List<Disturbance>(root["disturbances"], "disturbances",
                                          [this](auto& n, auto& f, auto* d) { Disturb(n, f, d); });
    }
    if (!root["people"].empty()) s->people = Integer(root["people"], "people");
    if (!root["surface_texture"].empty()) {
      s->surface_texture = Number(root["surface_texture"], "surface_texture");
    }
  }

 private:
  // Best-effort line of a dotted field ("accelerometer.rate_hz", "disturbances[1].end"):
  // each part is searched for after the line of the previous one; 0 when not found.
  int LineOf(const std::string& field) const {
    size_t line = 0;
    std::stringstream parts(field);
    for (std::string part; std::getline(parts, part, '.');) {
      int item = -1;
      const size_t bracket = part.find('[');
      if (bracket != std::string::npos) {
        item = std::atoi(part.c_str() + bracket + 1);
        part = part.substr(0, bracket);
      }
      const std::regex key("(^|[\\s{,-])" + part + "\\s*:");
      size_t found = line;
      while (found < lines_.size() && !std::regex_search(lines_[found], key)) ++found;
      if (found == lines_.size()) return 0;
      line = found;
      for (int i = 0; i <= item; ++i) {
        ++line;
        while (line < lines_.size() && Trim(lines_[line]).rfind("- ", 0) != 0) ++line;
        if (line == lines_.size()) return 0;
      }
    }
    return static_cast<int>(line) + 1;
  }

  void Keys(const cv::FileNode& map, const std::string& prefix,
            const std::set<std::string>& known) const {
    for (auto it = map.begin(); it != map.end(); ++it) {
      const std::string name = (*it).name();
      if (known.count(name) == 0) {
        std::string expected;
        for (const std::string& k : known) expected += (expected.empty() ? "" : ", ") + k;
        Fail(prefix + name, "unknown field, expected one of: " + expected);
      }
    }
  }

  std::string String(const cv::FileNode& node, const std::string& field) const {
    if (!node.isString()) Fail(field, "expected text");
    return static_cast<std::string>(node);
  }

  double Number(const cv::FileNode& node, const std::string& field) const {
    if (node.isInt() || node.isReal()) return static_cast<double>(node);
    Fail(field, "expected a number" + Got(node));
  }

  int Integer(const cv::FileNode& node, const std::string& field) const {
    if (node.isInt()) return static_cast<int>(node);
    Fail(field, "expected an integer" + Got(node));
  }

  ScenarioTime Time(const cv::FileNode& node, const std::string& field) const {
    if (node.isInt() || node.isReal()) return {static_cast<double>(node), false};
    ScenarioTime t;
    if (node.isString() && ParseTime(static_cast<std::string>(node), &t)) return t;
    Fail(field, "expected seconds (a number) or a fraction of the duration (\"50%\")" + Got(node));
  }

  Eigen::Vector3d Vector3(const cv::FileNode& node, const std::string& field) const {
    if (!node.isSeq() || node.size() != 3)
      Fail(field, "expected a list of three numbers [x, y, z]");
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = Number(node[i], field);
    return v;
  }

  static std::string Got(const cv::FileNode& node) {
    if (node.isString()) return ", got '" + static_cast<std::string>(node) + "'";
    if (node.isSeq()) return ", got a list";
    if (node.isMap()) return ", got a map";
    return "";
  }

  void Resolution(const cv::FileNode& node, Scenario* s) const {
    if (node.isSeq() && node.size() == 2 && node[0].isInt() && node[1].isInt()) {
      s->width = static_cast<int>(node[0]);
      s->height = static_cast<int>(node[1]);
      return;
    }
    if (node.isString() && ParseResolution(static_cast<std::string>(node), &s->width, &s->height)) {
      return;
    }
    Fail("resolution", "expected [width, height] or \"WIDTHxHEIGHT\"" + Got(node));
  }

  void Motion(const cv::FileNode& node, MotionOptions* m) const {
    if (node.isString()) {
      m->type = static_cast<std::string>(node);
      return;
    }
    if (!node.isMap()) Fail("motion", "expected walk, static or a map of motion fields");
    Keys(node, "motion.",
         {"type", "speed", "height", "step_hz", "bob", "sway", "scan_deg", "scan_hz", "pitch_deg",
          "pitch_swing_deg", "roll_deg"});
    if (!node["type"].empty()) m->type = String(node["type"], "motion.type");
    Optional(node, "speed", "motion.", &m->speed_mps);
    Optional(node, "height", "motion.", &m->height_m);
    Optional(node, "step_hz", "motion.", &m->step_hz);
    Optional(node, "bob", "motion.", &m->bob_m);
    Optional(node, "sway", "motion.", &m->sway_m);
    Optional(node, "scan_deg", "motion.", &m->scan_deg);
    Optional(node, "scan_hz", "motion.", &m->scan_hz);
    Optional(node, "pitch_deg", "motion.", &m->pitch_deg);
    Optional(node, "pitch_swing_deg", "motion.", &m->pitch_swing_deg);
    Optional(node, "roll_deg", "motion.", &m->roll_deg);
  }

  void Accelerometer(const cv::FileNode& node, AccelerometerOptions* a) const {
    if (!node.isMap()) Fail("accelerometer", "expected a map of fields");
    Keys(node, "accelerometer.",
         {"rate_hz", "noise_density", "bias", "range_g", "bits", "misalignment_deg"});
    Optional(node, "rate_hz", "accelerometer.", &a->rate_hz);
    Optional(node, "noise_density", "accelerometer.", &a->noise_density);
    Optional(node, "range_g", "accelerometer.", &a->range_g);
    if (!node["bias"].empty()) a->bias = Vector3(node["bias"], "accelerometer.bias");
    if (!node["bits"].empty()) a->bits = Integer(node["bits"], "accelerometer.bits");
    if (!node["misalignment_deg"].empty()) {
      a->misalignment_deg = Vector3(node["misalignment_deg"], "accelerometer.misalignment_deg");
    }
  }

  void Image(const cv::FileNode& node, ImageOptions* image) const {
    if (!node.isMap()) Fail("image", "expected a map of fields");
    Keys(node, "image.",
         {"noise_sigma", "vignetting", "chromatic_px", "supersampling", "readout_ms",
          "exposure_ms"});
    Optional(node, "noise_sigma", "image.", &image->noise_sigma);
    Optional(node, "vignetting", "image.", &image->vignetting);
    Optional(node, "chromatic_px", "image.", &image->chromatic_px);
    Optional(node, "readout_ms", "image.", &image->readout_ms);
    Optional(node, "exposure_ms", "image.", &image->exposure_ms);
    if (!node["supersampling"].empty()) {
      image->supersampling = Integer(node["supersampling"], "image.supersampling");
    }
  }

  void Checkerboard(const cv::FileNode& node, CheckerboardOptions* c) const {
    if (!node.isMap()) Fail("checkerboard", "expected a map of fields");
    Keys(node, "checkerboard.", {"squares_x", "squares_y", "square_m"});
    if (!node["squares_x"].empty())
      c->squares_x = Integer(node["squares_x"], "checkerboard.squares_x");
    if (!node["squares_y"].empty())
      c->squares_y = Integer(node["squares_y"], "checkerboard.squares_y");
    Optional(node, "square_m", "checkerboard.", &c->square_m);
  }

  void Event(const cv::FileNode& node, const std::string& field, IntrinsicsEvent* e) const {
    Keys(node, field + ".", {"start", "end", "fx_scale", "fy_scale", "cx_px", "cy_px"});
    if (node["start"].empty()) Fail(field + ".start", "missing; expected the start time");
    e->start = Time(node["start"], field + ".start");
    e->end = node["end"].empty() ? e->start : Time(node["end"], field + ".end");
    Optional(node, "fx_scale", field + ".", &e->fx_scale);
    Optional(node, "fy_scale", field + ".", &e->fy_scale);
    Optional(node, "cx_px", field + ".", &e->cx_px);
    Optional(node, "cy_px", field + ".", &e->cy_px);
  }

  void Disturb(const cv::FileNode& node, const std::string& field, Disturbance* d) const {
    Keys(node, field + ".", {"kind", "start", "end", "blur_sigma_px", "contrast", "noise_sigma"});
    const std::string kind = node["kind"].empty() ? "" : String(node["kind"], field + ".kind");
    if (kind == "fog") {
      d->kind = Disturbance::Kind::kFog;
    } else if (kind == "noise_burst") {
      d->kind = Disturbance::Kind::kNoiseBurst;
    } else {
      Fail(field + ".kind", "expected fog or noise_burst, got '" + kind + "'");
    }
    if (node["start"].empty()) Fail(field + ".start", "missing; expected the start time");
    if (node["end"].empty()) Fail(field + ".end", "missing; expected the end time");
    d->start = Time(node["start"], field + ".start");
    d->end = Time(node["end"], field + ".end");
    Optional(node, "blur_sigma_px", field + ".", &d->blur_sigma_px);
    Optional(node, "contrast", field + ".", &d->contrast);
    Optional(node, "noise_sigma", field + ".", &d->noise_sigma);
  }

  template <typename T, typename ReadItem>
  std::vector<T> List(const cv::FileNode& node, const std::string& field, ReadItem read) const {
    if (!node.isSeq()) Fail(field, "expected a list");
    std::vector<T> items(node.size());
    for (size_t i = 0; i < node.size(); ++i) {
      const std::string item_field = field + "[" + std::to_string(i) + "]";
      const cv::FileNode item = node[static_cast<int>(i)];
      if (!item.isMap()) Fail(item_field, "expected a map of fields");
      read(item, item_field, &items[i]);
    }
    return items;
  }

  void Optional(const cv::FileNode& map, const char* key, const std::string& prefix,
                double* value) const {
    if (!map[key].empty()) *value = Number(map[key], prefix + key);
  }

  std::string file_;
  std::vector<std::string> lines_;
};

Scenario ParseScenarioText(const std::string& file, const std::string& text,
                           const std::string& default_name) {
  // OpenCV's YAML reader wants its directive line; scenario files may leave it out.
  const bool has_directive = text.rfind("%YAML", 0) == 0;
  const std::string yaml = has_directive ? text : "%YAML:1.0\n" + text;
  cv::FileStorage storage;
  try {
    storage.open(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    // OpenCV reports "...(LINE): what" in its message.
    std::smatch match;
    static const std::regex kLine(R"(\((\d+)\): ([^\n]*))");
    int line = 0;
    std::string what = e.msg;
    if (std::regex_search(e.msg, match, kLine)) {
      line = std::stoi(match[1]) - (has_directive ? 0 : 1);
      what = match[2];
    }
    throw Error(file, line, "not valid YAML (" + Trim(what) + ")");
  }
  if (!storage.isOpened()) throw Error(file, 0, "not valid YAML");
  Scenario scenario;
  scenario.name = default_name;
  ScenarioReader reader(file, text);
  reader.Read(storage.root(), &scenario);
  std::string why;
  if (!scenario.Check(&why)) {
    const std::string field = why.substr(0, why.find(':'));
    reader.Fail(field, why.substr(std::min(why.size(), why.find(':') + 2)));
  }
  return scenario;
}

// Sets one field; the caller checks the whole scenario.
void SetField(Scenario* scenario, const std::string& key, const std::string& value) {
  Scenario& s = *scenario;
  auto number = [&](double* field) {
    if (!ParseNumber(value, field)) throw Error(key + ": expected a number, got '" + value + "'");
  };
  auto integer = [&](auto* field, long long lo, long long hi) {
    long long v = 0;
    if (!ParseInt(value, &v) || v < lo || v > hi) {
      throw Error(key + ": expected an integer in [" + std::to_string(lo) + ", " +
                  std::to_string(hi) + "], got '" + value + "'");
    }
    *field = static_cast<std::remove_pointer_t<decltype(field)>>(v);
  };
  if (key == "lens") {
    s.lens = value;
  } else if (key == "scene") {
    s.scene = value;
  } else if (key == "motion") {
    s.motion.type = value;
  } else if (key == "seconds") {
    number(&s.seconds);
  } else if (key == "fps") {
    number(&s.fps);
  } else if (key == "resolution") {
    if (!ParseResolution(value, &s.width, &s.height)) {
      throw Error("resolution: expected WIDTHxHEIGHT (e.g. 640x480), got '" + value + "'");
    }
  } else if (key == "seed") {
    integer(&s.seed, 0, 0x7fffffff);
  } else if (key == "accel_rate") {
    number(&s.accelerometer.rate_hz);
  } else if (key == "accel_noise") {
    number(&s.accelerometer.noise_density);
  } else if (key == "accel_range_g") {
    number(&s.accelerometer.range_g);
  } else if (key == "accel_bits") {
    integer(&s.accelerometer.bits, 0, 32);
  } else if (key == "noise_sigma") {
    number(&s.image.noise_sigma);
  } else if (key == "vignetting") {
    number(&s.image.vignetting);
  } else if (key == "chromatic_px") {
    number(&s.image.chromatic_px);
  } else if (key == "supersampling") {
    integer(&s.image.supersampling, 1, 8);
  } else if (key == "readout_ms") {
    number(&s.image.readout_ms);
  } else if (key == "exposure_ms") {
    number(&s.image.exposure_ms);
  } else if (key == "people") {
    integer(&s.people, 0, kMostPeople);
  } else if (key == "surface_texture") {
    number(&s.surface_texture);
  } else {
    throw Error("unknown scenario override '" + key +
                "', expected one of: scene, lens, motion, seconds, fps, resolution, seed, "
                "accel_rate, accel_noise, accel_range_g, accel_bits, noise_sigma, vignetting, "
                "chromatic_px, supersampling, readout_ms, exposure_ms, people, surface_texture");
  }
}

}  // namespace

std::vector<std::string> BuiltInScenarioNames() {
  std::vector<std::string> names;
  for (const BuiltInScenario& s : BuiltInScenarios()) names.push_back(s.name);
  return names;
}

Scenario LoadScenario(const std::string& name_or_path) {
  for (const BuiltInScenario& s : BuiltInScenarios()) {
    if (name_or_path == s.name) {
      return ParseScenarioText(std::string(s.name) + ".yaml (built in)", s.yaml, s.name);
    }
  }
  const std::filesystem::path path(name_or_path);
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::string names;
    for (const std::string& n : BuiltInScenarioNames()) names += (names.empty() ? "" : ", ") + n;
    throw Error(name_or_path, 0,
                "no such scenario: expected a built-in scenario (" + names +
                    ") or a readable scenario YAML file");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return ParseScenarioText(name_or_path, text.str(), path.stem().string());
}

void ApplyScenarioOverride(Scenario* scenario, const std::string& key, const std::string& value) {
  Scenario s = *scenario;
  SetField(&s, key, value);
  std::string why;
  if (!s.Check(&why)) throw Error(key + "=" + value + ": " + why);
  *scenario = s;
}

Scenario ParseScenarioSpec(const std::string& spec) {
  std::vector<std::string> parts;
  std::stringstream in(spec);
  for (std::string part; std::getline(in, part, ',');) parts.push_back(Trim(part));
  if (parts.empty() || parts.front().empty()) {
    throw Error("empty scenario spec, expected NAME_OR_PATH[,key=value...]");
  }
  Scenario scenario = LoadScenario(parts.front());
  for (size_t i = 1; i < parts.size(); ++i) {
    const size_t eq = parts[i].find('=');
    if (eq == std::string::npos) {
      throw Error("scenario spec '" + spec + "': expected key=value, got '" + parts[i] + "'");
    }
    SetField(&scenario, Trim(parts[i].substr(0, eq)), Trim(parts[i].substr(eq + 1)));
  }
  // Checked once all are set, so that "scene=checkerboard,motion=static" may be given in
  // either order.
  std::string why;
  if (!scenario.Check(&why)) throw Error("scenario spec '" + spec + "': " + why);
  return scenario;
}

}  // namespace autocal
