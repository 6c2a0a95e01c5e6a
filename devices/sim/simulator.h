// The simulator's public face: scenarios and a random-access simulated sequence.
// Everything else of the simulator lives in devices/sim/ behind this header.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "devices/sequence.h"
#include "devices/sim/scenario.h"

namespace autocal {

// Names of the built-in scenarios ("office", "corridor", ...).
std::vector<std::string> BuiltInScenarioNames();

// A built-in scenario by name, or a scenario YAML file by path. Throws Error naming the
// file, the line where it can, and what was expected.
Scenario LoadScenario(const std::string& name_or_path);

// Sets one field from text, as the CLI and "sim:" specs give it: lens=sonnar,
// seconds=10, resolution=640x480, seed=3, fps=30, accel_rate=800, ... Throws Error for
// an unknown key or a value that does not parse or is out of range.
void ApplyScenarioOverride(Scenario* scenario, const std::string& key, const std::string& value);

// "office" or "office,lens=sonnar,seconds=10,resolution=640x480" (the part after "sim:").
Scenario ParseScenarioSpec(const std::string& spec);

// Renders frames on demand (deterministic given the scenario's seed: frame i is the same
// image whichever order frames are asked for, from any thread).
std::unique_ptr<Sequence> MakeSimulatedSequence(const Scenario& scenario);

// The scene as YAML text: every plane with its id, name, corners in the world frame and
// size (written to ground_truth/scene.yaml).
std::string SceneDescriptionYaml(const Scenario& scenario);

}  // namespace autocal
