// flight_recorder's record: `rosbag record` for this project's options, single-threaded (see recorder.h).
#include <iostream>

#include "flight_recorder/bag_files.h"
#include "flight_recorder/recorder.h"
#include "flight_recorder/stop_signals.h"

int main(int argc, char** argv) {
  flight_recorder::blockStopSignals();  // before roscpp starts its threads
  flight_recorder::RecorderOptions options;
  try {
    options = flight_recorder::parseOptions(argc, argv);
  } catch (const flight_recorder::OptionError& error) {
    std::cerr << argv[0] << ": " << error.what() << "\n\n" << flight_recorder::usage(argv[0]);
    return 2;
  }
  if (options.show_help) {
    std::cout << flight_recorder::usage(argv[0]);
    return 0;
  }
  const std::tm now{};  // the date does not change the directory
  if (auto problem = flight_recorder::outputDirectoryProblem(flight_recorder::bagName(options, now, 0))) {
    std::cerr << argv[0] << ": cannot record: " << *problem << "\n";
    return 1;
  }
  // The name rosbag record has unless __name:= is given.
  ros::init(argc, argv, "record", ros::init_options::NoSigintHandler | ros::init_options::AnonymousName);
  flight_recorder::Recorder recorder(options);
  flight_recorder::StopSignals stop_signals([&recorder] { recorder.requestStop(); });
  flight_recorder::leaveGraphAndExit(recorder.run());
}
