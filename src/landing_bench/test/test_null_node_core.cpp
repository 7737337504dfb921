// The roscpp null node's arithmetic: publication credits and the header stamp of a serialised message.
#include <gtest/gtest.h>
#include <landing_bench/null_node_core.h>

#include <vector>

using landing_bench::headerStamp;
using landing_bench::PublicationCredit;

TEST(PublicationCredit, KeepsTheRateWhateverTheDriversRate) {
  PublicationCredit slower(20.0, 30.0);  // 20 Hz on a 30 Hz driver: 2 of every 3 events
  int sent = 0;
  for (int event = 0; event < 300; ++event) sent += slower.onDriverEvent();
  EXPECT_EQ(sent, 200);
  PublicationCredit faster(60.0, 20.0);  // 3 messages on each event
  EXPECT_EQ(faster.onDriverEvent(), 3);
  PublicationCredit no_driver(50.0, 0.0);  // an unknown driver rate: one message per event
  EXPECT_EQ(no_driver.onDriverEvent(), 1);
}

TEST(HeaderStamp, ReadsTheStampAfterTheSequenceNumber) {
  std::vector<uint8_t> message = {7, 0, 0, 0, 12, 0, 0, 0, 0x40, 0x42, 0x0f, 0, 99};  // seq 7, 12 s, 1,000,000 ns
  auto stamp = headerStamp(message.data(), message.size());
  ASSERT_TRUE(stamp.has_value());
  EXPECT_EQ(stamp->first, 12u);
  EXPECT_EQ(stamp->second, 1000000u);
  EXPECT_FALSE(headerStamp(message.data(), 11).has_value());
}
