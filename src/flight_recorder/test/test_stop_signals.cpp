#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "flight_recorder/stop_signals.h"

TEST(StopSignals, SigintAndSigtermCallOnStopInsteadOfKilling) {
  flight_recorder::blockStopSignals();
  std::atomic<int> stops{0};
  {
    flight_recorder::StopSignals signals([&stops] { ++stops; });
    kill(getpid(), SIGINT);
    for (int i = 0; i < 5000 && stops < 1; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    EXPECT_EQ(stops, 1);
    kill(getpid(), SIGTERM);
    for (int i = 0; i < 5000 && stops < 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    EXPECT_EQ(stops, 2);
  }  // the waiter thread ends here without a call
  EXPECT_EQ(stops, 2);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
