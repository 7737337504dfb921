#include <gtest/gtest.h>

#include "flight_recorder/recorder_options.h"

using flight_recorder::Compression;
using flight_recorder::OptionError;
using flight_recorder::parseOptions;
using flight_recorder::RecorderOptions;

namespace {

// The message of the OptionError that `args` raise ("" if none).
std::string errorOf(const std::vector<std::string>& args) {
  try {
    parseOptions(args);
  } catch (const OptionError& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST(RecorderOptions, TheProjectsCommandLine) {
  const RecorderOptions options = parseOptions({"--output-name=/x/flight.bag", "--split", "--duration=120", "--lz4",
                                                "--chunksize=32", "-e", "/(tf|tf_static|platform/.*)",
                                                "__name:=flight_recorder"});
  EXPECT_EQ(options.name_prefix, "/x/flight.bag");
  EXPECT_FALSE(options.append_date);
  EXPECT_TRUE(options.split);
  ASSERT_TRUE(options.max_duration_ns);
  EXPECT_EQ(*options.max_duration_ns, 120'000'000'000LL);
  EXPECT_EQ(options.compression, Compression::Lz4);
  EXPECT_EQ(options.chunk_size_bytes, 32u * 1024);
  EXPECT_TRUE(options.topics_are_regexes);
  EXPECT_EQ(options.topics, std::vector<std::string>{"/(tf|tf_static|platform/.*)"});
}

TEST(RecorderOptions, DefaultsAreRosbagRecords) {
  const RecorderOptions options = parseOptions({"/tf"});
  EXPECT_EQ(options.name_prefix, "");
  EXPECT_TRUE(options.append_date);
  EXPECT_FALSE(options.split);
  EXPECT_FALSE(options.max_duration_ns);
  EXPECT_EQ(options.compression, Compression::None);
  EXPECT_EQ(options.chunk_size_bytes, 768u * 1024);
  EXPECT_FALSE(options.topics_are_regexes);
}

TEST(RecorderOptions, SeparateValuesShortFormsAndBz2) {
  const RecorderOptions options = parseOptions({"-o", "/x/flight", "--duration", "1.5m", "-j", "--chunksize", "0",
                                                "--regex", "/a.*", "/b"});
  EXPECT_EQ(options.name_prefix, "/x/flight");
  EXPECT_TRUE(options.append_date);
  EXPECT_EQ(*options.max_duration_ns, 90'000'000'000LL);
  EXPECT_EQ(options.compression, Compression::Bz2);
  EXPECT_EQ(options.chunk_size_bytes, 0u);
  EXPECT_EQ(options.topics, (std::vector<std::string>{"/a.*", "/b"}));
}

TEST(RecorderOptions, PlainTopicsAreSortedOnceEach) {
  const RecorderOptions options = parseOptions({"-O", "x", "/tf", "/odom", "/tf", "a:=b"});
  EXPECT_EQ(options.topics, (std::vector<std::string>{"/odom", "/tf"}));
  EXPECT_FALSE(options.topics_are_regexes);
}

TEST(RecorderOptions, DurationUnits) {
  EXPECT_EQ(*parseOptions({"--duration=2h", "/t"}).max_duration_ns, 7200'000'000'000LL);
  EXPECT_EQ(*parseOptions({"--duration=0.25s", "/t"}).max_duration_ns, 250'000'000LL);
}

TEST(RecorderOptions, HelpNeedsNoTopics) {
  EXPECT_TRUE(parseOptions({"--help"}).show_help);
  EXPECT_TRUE(parseOptions({"-h"}).show_help);
}

TEST(RecorderOptions, BadInputSaysWhatIsWrong) {
  EXPECT_NE(errorOf({"--lz5", "/t"}).find("unknown option '--lz5'"), std::string::npos);
  EXPECT_NE(errorOf({"--all"}).find("not supported"), std::string::npos);
  EXPECT_NE(errorOf({"--chunksize=big", "/t"}).find("--chunksize"), std::string::npos);
  EXPECT_NE(errorOf({"--chunksize=-1", "/t"}).find("--chunksize"), std::string::npos);
  EXPECT_NE(errorOf({"--chunksize=", "/t"}).find("--chunksize"), std::string::npos);
  EXPECT_NE(errorOf({"--chunksize"}).find("needs a value"), std::string::npos);
  EXPECT_NE(errorOf({"--duration=0", "/t"}).find("positive"), std::string::npos);
  EXPECT_NE(errorOf({"--duration=-3", "/t"}).find("positive"), std::string::npos);
  EXPECT_NE(errorOf({"--duration=ten", "/t"}).find("number"), std::string::npos);
  EXPECT_NE(errorOf({"--duration=10d", "/t"}).find("unit"), std::string::npos);
  EXPECT_NE(errorOf({"--lz4", "--bz2", "/t"}).find("only one compression"), std::string::npos);
  EXPECT_NE(errorOf({"--lz4=1", "/t"}).find("takes no value"), std::string::npos);
  EXPECT_NE(errorOf({"--split=100", "/t"}).find("--split"), std::string::npos);
  EXPECT_NE(errorOf({"-O", "a", "-o", "b", "/t"}).find("not both"), std::string::npos);
  EXPECT_NE(errorOf({"--output-name=", "/t"}).find("non-empty"), std::string::npos);
  EXPECT_NE(errorOf({"--output-name=.bag", "/t"}).find("non-empty"), std::string::npos);
  EXPECT_NE(errorOf({"--lz4"}).find("no topics"), std::string::npos);
  EXPECT_NE(errorOf({"-e"}).find("regular expression"), std::string::npos);
  EXPECT_NE(errorOf({"-e", "/(unclosed"}).find("not a valid regular expression"), std::string::npos);
  EXPECT_NE(errorOf({"__name:=x"}).find("no topics"), std::string::npos);
}

TEST(RecorderOptions, UsageListsTheOptions) {
  const std::string text = flight_recorder::usage("record");
  for (const char* option : {"--output-name", "--output-prefix", "--split", "--duration", "--lz4", "--bz2",
                             "--chunksize", "--regex"}) {
    EXPECT_NE(text.find(option), std::string::npos) << option;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
