// Sonar and barometer readings at an image's stamp: the frame arrives 100-200 ms after it was taken,
// so the readings that go with it are in the past.
#include <cmath>

#include <gtest/gtest.h>

#include "uav_vision/reading_history.h"

namespace uav_vision::test {
namespace {

// A sonar at 25 Hz over a drone descending at 0.5 m/s from 2 m.
ReadingHistory descendingSonar(double until) {
  ReadingHistory history;
  for (int i = 0; i * 0.04 <= until + 1e-9; ++i) history.add(i * 0.04, 2.0 - 0.5 * i * 0.04);
  return history;
}

TEST(ReadingHistory, AFrameTakesTheReadingsOfItsCaptureTimeNotTheNewest) {
  const ReadingHistory history = descendingSonar(1.0);
  // The frame was taken at 0.8 s and arrives at 1.0 s: the newest reading is 10 cm lower.
  EXPECT_NEAR(history.nearest(0.81, 0.2), 2.0 - 0.5 * 0.80, 1e-12);
  EXPECT_NEAR(history.medianNear(0.81, 0.2), 2.0 - 0.5 * 0.80, 1e-12);
  EXPECT_NEAR(history.nearest(0.83, 0.2), 2.0 - 0.5 * 0.84, 1e-12);
}

TEST(ReadingHistory, TheMedianDropsASpuriousEcho) {
  ReadingHistory history = descendingSonar(0.76);
  history.add(0.80, 0.3);  // an early echo (rotor noise)
  for (int i = 21; i <= 25; ++i) history.add(i * 0.04, 2.0 - 0.5 * i * 0.04);
  EXPECT_NEAR(history.nearest(0.80, 0.2), 0.3, 1e-12);             // the nearest alone is the outlier
  EXPECT_NEAR(history.medianNear(0.80, 0.2), 2.0 - 0.5 * 0.84, 1e-12);  // of 0.76, 0.8, 0.84: a neighbour
  history.add(1.04, INFINITY);  // no echo at all: the median of 0.96, 1.0 and that
  EXPECT_NEAR(history.medianNear(1.04, 0.2), 2.0 - 0.5 * 0.96, 1e-12);
}

TEST(ReadingHistory, AStepToAnotherSurfaceIsNotBlended) {
  ReadingHistory history;
  history.add(0.00, 1.50);  // over the pad
  history.add(0.04, 1.50);
  history.add(0.08, 2.00);  // past its edge: the ground, 0.5 m lower
  history.add(0.12, 2.00);
  const double at_edge = history.medianNear(0.06, 0.2);
  EXPECT_TRUE(at_edge == 1.50 || at_edge == 2.00) << at_edge;
  EXPECT_EQ(history.nearest(0.07, 0.2), 2.00);
}

TEST(ReadingHistory, NothingNearTheStampIsNaN) {
  ReadingHistory history = descendingSonar(1.0);
  EXPECT_TRUE(std::isnan(history.nearest(1.5, 0.2)));
  EXPECT_TRUE(std::isnan(history.medianNear(-0.5, 0.2)));
  EXPECT_TRUE(std::isnan(ReadingHistory().medianNear(0.0, 1.0)));
  // Only two readings within reach: the nearer one, not their mean.
  EXPECT_NEAR(history.medianNear(1.03, 0.08), 2.0 - 0.5 * 1.0, 1e-12);
}

TEST(ReadingHistory, TheBarometerIsAveragedAroundTheStamp) {
  ReadingHistory history;  // 20 Hz, alternately 0.1 m above and below 5 m
  for (int i = 0; i <= 20; ++i) history.add(i * 0.05, 5.0 + (i % 2 ? 0.1 : -0.1));
  EXPECT_NEAR(history.meanNear(0.5, 0.11, 0.5), 5.0 - 0.1 / 5.0, 1e-9);  // five readings: three low, two high
  EXPECT_NEAR(history.meanNear(0.525, 0.05, 0.5), 5.0, 1e-9);          // two: one of each
  EXPECT_NEAR(history.meanNear(1.3, 0.1, 0.5), 4.9, 1e-9);              // none that close: the nearest
  EXPECT_TRUE(std::isnan(history.meanNear(2.0, 0.1, 0.5)));
}

TEST(ReadingHistory, KeepsASecondAndRestartsWhenTimeGoesBack) {
  ReadingHistory history = descendingSonar(3.0);
  EXPECT_TRUE(std::isnan(history.nearest(1.0, 0.2)));  // older than a second before the newest
  EXPECT_FALSE(std::isnan(history.nearest(2.5, 0.2)));
  history.add(0.5, 7.0);  // the clock went back (a new simulation)
  EXPECT_TRUE(std::isnan(history.nearest(2.5, 0.2)));
  EXPECT_EQ(history.nearest(0.5, 0.2), 7.0);
}

}  // namespace
}  // namespace uav_vision::test
