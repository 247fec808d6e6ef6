// A small result type for user and data errors (bad file, malformed line, unusable input).
// Programmer errors are CHECKs; exceptions never cross module boundaries.
#ifndef HETSLAM_CORE_STATUS_H_
#define HETSLAM_CORE_STATUS_H_

#include <string>
#include <utility>

namespace hetslam {

class Status {
 public:
  // An OK status.
  Status() = default;
  static Status Ok() { return Status(); }
  static Status Error(std::string message) { return Status(std::move(message)); }

  bool ok() const { return !failed_; }
  // Empty for an OK status; otherwise a message naming what failed and where
  // ("intel.clf:123: FLASER has 180 ranges but only 12 numbers follow").
  const std::string& message() const { return message_; }

 private:
  explicit Status(std::string message) : failed_(true), message_(std::move(message)) {}
  bool failed_ = false;
  std::string message_;
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_STATUS_H_
