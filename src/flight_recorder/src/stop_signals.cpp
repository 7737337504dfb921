#include "flight_recorder/stop_signals.h"

#include <pthread.h>
#include <signal.h>

namespace flight_recorder {
namespace {

sigset_t stopSignalSet() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  return signals;
}

}  // namespace

void blockStopSignals() {
  const sigset_t signals = stopSignalSet();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
}

StopSignals::StopSignals(std::function<void()> on_stop) : on_stop_(std::move(on_stop)) {
  waiter_ = std::thread([this] {
    const sigset_t signals = stopSignalSet();
    for (;;) {
      int signal_number = 0;
      if (sigwait(&signals, &signal_number) != 0) continue;
      if (finished_) return;
      on_stop_();
    }
  });
}

StopSignals::~StopSignals() {
  // Wakes the waiter with a signal of its own set, sent to that thread alone, so that it returns.
  finished_ = true;
  pthread_kill(waiter_.native_handle(), SIGTERM);
  waiter_.join();
}

}  // namespace flight_recorder
