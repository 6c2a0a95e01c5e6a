#include <cstdlib>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace {

// Seeds every generator the code under test might draw from, before every test.
class SeedRandomness : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo&) override {
    std::srand(0);
    cv::theRNG().state = 0x12345678;
  }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::UnitTest::GetInstance()->listeners().Append(new SeedRandomness);
  return RUN_ALL_TESTS();
}
