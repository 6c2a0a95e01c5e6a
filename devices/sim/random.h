// Deterministic seeds for the simulator's random streams: every stream (a frame's noise,
// a texture, the accelerometer) gets its own seed mixed from the scenario seed, so results
// do not depend on the order in which things are computed or on threads.
#pragma once

#include <cstdint>

namespace autocal {

// Stream tags mixed into seeds.
inline constexpr uint64_t kAccelerometerStream = 0xacce1;
inline constexpr uint64_t kTextureStream = 0x7e47;
inline constexpr uint64_t kFrameNoiseStream = 0xf7a3e;
inline constexpr uint64_t kPeopleStream = 0x9e091e;

// SplitMix64 finaliser over the combined inputs: well spread, never 0 (cv::RNG treats a
// zero state specially).
inline uint64_t MixSeed(uint64_t a, uint64_t b, uint64_t c = 0) {
  uint64_t z = a * 0x9e3779b97f4a7c15ULL + b;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL + c;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return z == 0 ? 1 : z;
}

}  // namespace autocal
