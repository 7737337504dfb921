// The names rosbag record gives its bags, which the stack's tools expect (runner.split_bags, analyze). ROS-free.
#pragma once

#include <ctime>
#include <string>

#include "flight_recorder/options.h"

namespace flight_recorder {

// Local time as rosbag record writes it into a prefixed bag's name: YYYY-MM-DD-HH-MM-SS.
std::string dateStamp(std::time_t when);

// The name of the bag number ``split_index`` (0 for the first; only used with --split): --output-name=NAME gives
// NAME.bag, with --split NAME_0.bag, NAME_1.bag ...; --output-prefix=PREFIX gives PREFIX_DATE.bag (and _0, _1 ...);
// neither gives DATE.bag. ``date`` is dateStamp() of the recording's start.
std::string bagName(const Options& options, int split_index, const std::string& date);

// The name a bag has while it is written: NAME.bag.active (renamed to NAME.bag once closed).
std::string activeName(const std::string& bag_name);

}  // namespace flight_recorder
