#include <gtest/gtest.h>

#include "flight_recorder/topic_selection.h"

using flight_recorder::TopicSelection;

TEST(TopicSelection, RegexMustMatchTheWholeName) {
  const TopicSelection selection({"/(tf|tf_static|platform/.*)"}, true);
  EXPECT_TRUE(selection.needsDiscovery());
  EXPECT_TRUE(selection.matches("/tf"));
  EXPECT_TRUE(selection.matches("/tf_static"));
  EXPECT_TRUE(selection.matches("/platform/pose"));
  EXPECT_FALSE(selection.matches("/tf2"));             // a prefix match is not enough
  EXPECT_FALSE(selection.matches("/ns/tf"));           // nor a suffix
  EXPECT_FALSE(selection.matches("/platform"));
  EXPECT_FALSE(selection.matches("tf"));
}

TEST(TopicSelection, AnyOfSeveralExpressions) {
  const TopicSelection selection({"/a/.*", "/b"}, true);
  EXPECT_TRUE(selection.matches("/a/x"));
  EXPECT_TRUE(selection.matches("/b"));
  EXPECT_FALSE(selection.matches("/bb"));
}

TEST(TopicSelection, PerlSyntaxAsBoostRegexHasIt) {
  const TopicSelection selection({"/ardrone/(?:imu|sonar_height)|/kalman_\\w+"}, true);
  EXPECT_TRUE(selection.matches("/ardrone/imu"));
  EXPECT_TRUE(selection.matches("/kalman_pose"));
  EXPECT_FALSE(selection.matches("/kalman_"));
}

TEST(TopicSelection, NewMatchingTopicsOfTheMastersListOnceEach) {
  const TopicSelection selection({"/(tf|tf_static|platform/.*)"}, true);
  const std::vector<std::string> published{"/rosout", "/platform/pose", "/tf", "/camera/image", "/tf", "/tf_static"};
  EXPECT_EQ(selection.topicsToSubscribe(published, {}),
            (std::vector<std::string>{"/platform/pose", "/tf", "/tf_static"}));
  EXPECT_EQ(selection.topicsToSubscribe(published, {"/tf", "/platform/pose"}),
            (std::vector<std::string>{"/tf_static"}));
  EXPECT_TRUE(selection.topicsToSubscribe(published, {"/tf", "/platform/pose", "/tf_static"}).empty());
}

TEST(TopicSelection, PlainNamesAreFixedAndNeedNoDiscovery) {
  const TopicSelection selection({"/odom", "/tf"}, false);
  EXPECT_FALSE(selection.needsDiscovery());
  EXPECT_EQ(selection.fixedTopics(), (std::vector<std::string>{"/odom", "/tf"}));
  EXPECT_TRUE(selection.topicsToSubscribe({"/odom", "/tf"}, {}).empty());
}

TEST(DiscoveryPeriod, OftenAtStartThenOnceASecond) {
  EXPECT_DOUBLE_EQ(flight_recorder::discoveryPeriodS(0.0), 0.1);
  EXPECT_DOUBLE_EQ(flight_recorder::discoveryPeriodS(4.9), 0.1);
  EXPECT_DOUBLE_EQ(flight_recorder::discoveryPeriodS(5.0), 1.0);
  EXPECT_DOUBLE_EQ(flight_recorder::discoveryPeriodS(3600.0), 1.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
