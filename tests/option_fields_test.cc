// Every field of every option struct of the pipeline is bound in PipelineOptionFields (and
// so in the workbench's threshold panel, `autocal run --set` and settings files): a field
// added to a struct without a binding fails here. C++20 has no reflection; an option struct
// is an aggregate, and the number of its members is the most initializers it takes.
#include <cstddef>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "pipeline/option_fields.h"

namespace autocal {
namespace {

// Converts to any member's type, so that T{AnyMember{}, ...} compiles for as many
// initializers as T has members and no more (no brace elision: the conversion is taken).
struct AnyMember {
  template <typename T>
  operator T() const;  // Never called: only unevaluated.
};

template <typename T, size_t... Indices>
constexpr bool TakesInitializers(std::index_sequence<Indices...>) {
  return requires { T{(void(Indices), AnyMember{})...}; };
}

template <typename T, size_t N = 0>
constexpr size_t MemberCount() {
  if constexpr (TakesInitializers<T>(std::make_index_sequence<N + 1>{})) {
    return MemberCount<T, N + 1>();
  } else {
    return N;
  }
}

// The worked example: three members, one of them a struct.
struct Inner {
  int a = 0;
  double b = 0;
};
struct Outer {
  Inner inner;
  bool flag = false;
  double value = 1.0;
};
static_assert(MemberCount<Inner>() == 2);
static_assert(MemberCount<Outer>() == 3);

// How many fields are bound directly in the struct at `path` ("lens.lines").
int BoundFields(const std::string& path) {
  int count = 0;
  for (const OptionField& field : PipelineOptionFields()) {
    const size_t dot = field.name.rfind('.');
    if (field.name.substr(0, dot) == path) ++count;
  }
  return count;
}

struct OptionStruct {
  std::string path;       // Where it sits in PipelineOptions.
  size_t members;         // Its members...
  int nested;             // ...of which this many are option structs listed here too.
};

TEST(OptionFields, EveryMemberOfEveryOptionStructIsBound) {
  const OptionStruct structs[] = {
      {"lens", MemberCount<LensOptions>(), 4},
      {"lens.lines", MemberCount<LineDetectorOptions>(), 0},
      {"lens.snakes", MemberCount<SnakeOptions>(), 0},
      {"lens.plumb_line", MemberCount<PlumbLineOptions>(), 0},
      {"lens.rectify", MemberCount<RectifyOptions>(), 0},
      {"motion", MemberCount<MotionStageOptions>(), 2},
      {"motion.flow", MemberCount<FlowOptions>(), 1},
      {"motion.flow.features", MemberCount<FeatureOptions>(), 0},
      {"motion.planes", MemberCount<PlaneOptions>(), 0},
      {"inertial", MemberCount<InertialOptions>(), 4},
      {"inertial.screen", MemberCount<AccelScreenOptions>(), 0},
      {"inertial.quasi_static", MemberCount<QuasiStaticOptions>(), 0},
      {"inertial.motion", MemberCount<MotionClassOptions>(), 0},
      {"inertial.scale", MemberCount<ScaleOptions>(), 0},
      {"board", MemberCount<VirtualBoardOptions>(), 0},
      {"material", MemberCount<MaterialOptions>(), 2},
      {"material.quality", MemberCount<ImageQualityOptions>(), 0},
      {"material.anchor", MemberCount<AnchorOptions>(), 0},
      {"calibration", MemberCount<SelfCalibrationOptions>(), 0},
      {"acceptance", MemberCount<AcceptanceOptions>(), 0},
  };
  EXPECT_EQ(MemberCount<PipelineOptions>(), 7u) << "a new option struct: list it above";
  size_t bound = 0;
  for (const OptionStruct& s : structs) {
    EXPECT_EQ(size_t(BoundFields(s.path) + s.nested), s.members)
        << s.path << ": " << BoundFields(s.path) << " fields bound, " << s.nested
        << " nested structs, " << s.members << " members";
    bound += BoundFields(s.path);
  }
  EXPECT_EQ(bound, PipelineOptionFields().size()) << "a field bound outside the structs above";
}

}  // namespace
}  // namespace autocal
