#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "flight_recorder/bag_files.h"

using flight_recorder::activeBagName;
using flight_recorder::bagName;
using flight_recorder::outputDirectoryProblem;
using flight_recorder::parseOptions;
using flight_recorder::SplitSchedule;

namespace {

std::tm date(int year, int month, int day, int hour, int minute, int second) {
  std::tm t{};
  t.tm_year = year - 1900;
  t.tm_mon = month - 1;
  t.tm_mday = day;
  t.tm_hour = hour;
  t.tm_min = minute;
  t.tm_sec = second;
  return t;
}

const std::tm kDate = date(2024, 3, 7, 9, 5, 2);
constexpr int64_t kSecond = 1'000'000'000;

}  // namespace

TEST(BagName, OutputNameIsExactWithBagAppended) {
  EXPECT_EQ(bagName(parseOptions({"--output-name=/x/flight.bag", "/t"}), kDate, 0), "/x/flight.bag");
  EXPECT_EQ(bagName(parseOptions({"--output-name=/x/flight", "/t"}), kDate, 0), "/x/flight.bag");
  EXPECT_EQ(bagName(parseOptions({"-O", "flight.2.bag", "/t"}), kDate, 0), "flight.2.bag");
}

TEST(BagName, SplitOutputNameGetsTheIndexBeforeBag) {
  const auto options = parseOptions({"--output-name=/x/flight.bag", "--split", "--duration=600", "/t"});
  EXPECT_EQ(bagName(options, kDate, 0), "/x/flight_0.bag");
  EXPECT_EQ(bagName(options, kDate, 1), "/x/flight_1.bag");
  EXPECT_EQ(bagName(options, kDate, 12), "/x/flight_12.bag");
}

TEST(BagName, OutputPrefixGetsTheDate) {
  EXPECT_EQ(bagName(parseOptions({"--output-prefix=/home/u/.ros/flight", "/t"}), kDate, 0),
            "/home/u/.ros/flight_2024-03-07-09-05-02.bag");
  EXPECT_EQ(bagName(parseOptions({"--output-prefix=/x/flight.bag", "/t"}), kDate, 0),
            "/x/flight_2024-03-07-09-05-02.bag");
  EXPECT_EQ(bagName(parseOptions({"/t"}), kDate, 0), "2024-03-07-09-05-02.bag");
}

TEST(BagName, SplitOutputPrefixGetsDateThenIndex) {
  const auto options = parseOptions({"--output-prefix=/x/flight", "--split", "--duration=10", "/t"});
  EXPECT_EQ(bagName(options, kDate, 0), "/x/flight_2024-03-07-09-05-02_0.bag");
  EXPECT_EQ(bagName(options, date(2024, 12, 31, 23, 59, 59), 3), "/x/flight_2024-12-31-23-59-59_3.bag");
}

TEST(BagName, ActiveWhileWritten) { EXPECT_EQ(activeBagName("/x/flight_0.bag"), "/x/flight_0.bag.active"); }

TEST(SplitSchedule, NewBagOnlyPastTheDuration) {
  SplitSchedule schedule(100 * kSecond, 10 * kSecond);
  EXPECT_EQ(schedule.endsPassed(105 * kSecond), 0u);
  EXPECT_EQ(schedule.endsPassed(110 * kSecond), 0u);  // exactly at the end: still this bag (rosbag's '>')
  EXPECT_EQ(schedule.endsPassed(110 * kSecond + 1), 1u);
  EXPECT_EQ(schedule.currentStartNs(), 110 * kSecond);
  EXPECT_EQ(schedule.endsPassed(115 * kSecond), 0u);
}

TEST(SplitSchedule, AGapPassesOneEndPerDuration) {
  SplitSchedule schedule(0, 10 * kSecond);
  EXPECT_EQ(schedule.endsPassed(35 * kSecond), 3u);  // bags of [10, 20) and [20, 30) are empty, as rosbag's
  EXPECT_EQ(schedule.currentStartNs(), 30 * kSecond);
}

TEST(SplitSchedule, WithoutDurationNever) {
  SplitSchedule schedule(0, std::nullopt);
  EXPECT_EQ(schedule.endsPassed(1'000'000 * kSecond), 0u);
}

TEST(OutputDirectory, MissingOrUnwritableIsNamed) {
  EXPECT_FALSE(outputDirectoryProblem("flight.bag"));  // the current directory (the test's build folder)
  char pattern[] = "/tmp/flight_recorder_test_XXXXXX";
  const std::string directory = mkdtemp(pattern);
  EXPECT_FALSE(outputDirectoryProblem(directory + "/flight.bag"));

  const auto missing = outputDirectoryProblem(directory + "/missing/flight.bag");
  ASSERT_TRUE(missing);
  EXPECT_NE(missing->find(directory + "/missing"), std::string::npos) << *missing;
  EXPECT_NE(missing->find("No such file or directory"), std::string::npos) << *missing;

  const std::string file = directory + "/file";
  FILE* f = std::fopen(file.c_str(), "w");
  std::fclose(f);
  EXPECT_TRUE(outputDirectoryProblem(file + "/flight.bag"));

  if (geteuid() != 0) {  // root may write anywhere
    chmod(directory.c_str(), 0500);
    const auto unwritable = outputDirectoryProblem(directory + "/flight.bag");
    ASSERT_TRUE(unwritable);
    EXPECT_NE(unwritable->find("not writable"), std::string::npos);
    chmod(directory.c_str(), 0700);
  }
  unlink(file.c_str());
  rmdir(directory.c_str());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
