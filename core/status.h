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

// Evaluates `expr` (a Status) once and, when it is an error, returns it from the enclosing
// function (which must return Status):
//   HETSLAM_RETURN_IF_ERROR(ParseHeader(line, &header));
#define HETSLAM_RETURN_IF_ERROR(expr)                                       \
  do {                                                                      \
    ::hetslam::Status hetslam_macro_status = (expr);                        \
    if (!hetslam_macro_status.ok()) return hetslam_macro_status;            \
  } while (0)

#endif  // HETSLAM_CORE_STATUS_H_
