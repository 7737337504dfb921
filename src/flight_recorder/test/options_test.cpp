// The recorder's command line, topic selection and bag names (ROS-free).
#include <gtest/gtest.h>

#include "flight_recorder/bag_names.h"
#include "flight_recorder/options.h"

using flight_recorder::Options;
using flight_recorder::OptionError;
using flight_recorder::parseOptions;

namespace {
Options parse(std::vector<std::string> args) { return parseOptions(args); }
}  // namespace

TEST(Options, TheFlightRecordersCommandLine) {
  // What landing_eval's runner passes (runner.recorder_command).
  const Options o = parse({"--output-name=/tmp/x/flight.bag", "--split", "--duration=120", "--lz4", "--chunksize=32",
                           "-e", "/(ardrone/imu|tf)"});
  EXPECT_EQ(o.output_name, "/tmp/x/flight.bag");
  EXPECT_TRUE(o.split);
  EXPECT_DOUBLE_EQ(o.duration_s, 120.0);
  EXPECT_EQ(o.compression, flight_recorder::Compression::kLz4);
  EXPECT_EQ(o.chunk_kb, 32u);
  EXPECT_TRUE(o.regex);
  ASSERT_EQ(o.topics.size(), 1u);
  EXPECT_EQ(o.topics[0], "/(ardrone/imu|tf)");
}

TEST(Options, ValuesMayFollowAsTheNextArgument) {
  const Options o = parse({"-O", "a.bag", "--chunksize", "64", "-j", "/tf"});
  EXPECT_EQ(o.output_name, "a.bag");
  EXPECT_EQ(o.chunk_kb, 64u);
  EXPECT_EQ(o.compression, flight_recorder::Compression::kBz2);
  EXPECT_FALSE(o.regex);
  EXPECT_EQ(parse({"-o", "/tmp/flight", "-a"}).output_prefix, "/tmp/flight");
}

TEST(Options, DurationsInSecondsMinutesHours) {
  EXPECT_DOUBLE_EQ(flight_recorder::parseDuration("30"), 30.0);
  EXPECT_DOUBLE_EQ(flight_recorder::parseDuration("1.5s"), 1.5);
  EXPECT_DOUBLE_EQ(flight_recorder::parseDuration("5m"), 300.0);
  EXPECT_DOUBLE_EQ(flight_recorder::parseDuration("2h"), 7200.0);
  for (const char* bad : {"", "x", "10q", "-3", "0", "nan"}) {
    EXPECT_THROW(flight_recorder::parseDuration(bad), OptionError) << bad;
  }
}

TEST(Options, BadCommandLinesSayWhatIsWrong) {
  auto message = [](std::vector<std::string> args) {
    try {
      parseOptions(args);
    } catch (const OptionError& error) {
      return std::string(error.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_NE(message({"--size=10", "/tf"}).find("unknown option '--size=10'"), std::string::npos);
  EXPECT_NE(message({"--output-name"}).find("needs a value"), std::string::npos);
  EXPECT_NE(message({"--split", "/tf"}).find("--split needs --duration"), std::string::npos);
  EXPECT_NE(message({"--lz4"}).find("no topics to record"), std::string::npos);
  EXPECT_NE(message({"-e", "/(unclosed"}).find("bad regular expression"), std::string::npos);
  EXPECT_NE(message({"--chunksize=0", "/tf"}).find("--chunksize must be"), std::string::npos);
  EXPECT_NE(message({"--chunksize=12kb", "/tf"}).find("--chunksize must be"), std::string::npos);
  EXPECT_NE(message({"-O", "a.bag", "-o", "b", "/tf"}).find("not both"), std::string::npos);
  EXPECT_TRUE(parse({"--help"}).help);
}

TEST(TopicFilter, AnExpressionMustMatchTheWholeName) {
  const flight_recorder::TopicFilter filter(parse({"-e", "/(ardrone/(imu|navdata)|groundtruth/.*)"}));
  EXPECT_TRUE(filter.wanted("/ardrone/imu"));
  EXPECT_TRUE(filter.wanted("/groundtruth/landing_pad"));
  EXPECT_FALSE(filter.wanted("/ardrone/imu_raw"));  // (rosbag record's regex_match, not a search)
  EXPECT_FALSE(filter.wanted("/x/ardrone/imu"));
  EXPECT_FALSE(filter.wanted("/ardrone/bottom/image_raw"));
}

TEST(TopicFilter, NamesAreResolvedFromTheRootAndAllTakesEverything) {
  const flight_recorder::TopicFilter names(parse({"tf", "/ardrone/imu"}));
  EXPECT_TRUE(names.wanted("/tf"));
  EXPECT_TRUE(names.wanted("/ardrone/imu"));
  EXPECT_FALSE(names.wanted("/tf_static"));
  EXPECT_TRUE(flight_recorder::TopicFilter(parse({"-a"})).wanted("/anything"));
}

TEST(BagNames, AsRosbagRecordNamesThem) {
  const std::string date = "2026-12-01-21-04-12";
  EXPECT_EQ(flight_recorder::bagName(parse({"-O", "/r/flight.bag", "/tf"}), 0, date), "/r/flight.bag");
  EXPECT_EQ(flight_recorder::bagName(parse({"-O", "/r/flight", "/tf"}), 0, date), "/r/flight.bag");
  const Options split = parse({"-O", "/r/flight.bag", "--split", "--duration=120", "/tf"});
  EXPECT_EQ(flight_recorder::bagName(split, 0, date), "/r/flight_0.bag");
  EXPECT_EQ(flight_recorder::bagName(split, 3, date), "/r/flight_3.bag");
  EXPECT_EQ(flight_recorder::bagName(parse({"-o", "/home/u/.ros/flight", "/tf"}), 0, date),
            "/home/u/.ros/flight_2026-12-01-21-04-12.bag");
  EXPECT_EQ(flight_recorder::bagName(parse({"-o", "/p", "--split", "--duration=600", "/tf"}), 1, date),
            "/p_2026-12-01-21-04-12_1.bag");
  EXPECT_EQ(flight_recorder::bagName(parse({"/tf"}), 0, date), "2026-12-01-21-04-12.bag");
  EXPECT_EQ(flight_recorder::activeName("/r/flight_0.bag"), "/r/flight_0.bag.active");
}

TEST(BagNames, TheDateIsLocalTime) {
  setenv("TZ", "UTC", 1);
  tzset();
  EXPECT_EQ(flight_recorder::dateStamp(1796159556), "2026-12-01-21-12-36");
}
