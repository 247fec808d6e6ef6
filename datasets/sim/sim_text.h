// Number formatting shared by the simulators (log comments, PARAM values) and the scenario
// parser (error messages).
#ifndef HETSLAM_DATASETS_SIM_SIM_TEXT_H_
#define HETSLAM_DATASETS_SIM_SIM_TEXT_H_

#include <ios>
#include <sstream>
#include <string>

namespace hetslam {
namespace sim {

// `value` in fixed notation with `digits` decimals ("0.350" for Fixed(0.35, 3)).
inline std::string Fixed(double value, int digits) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(digits);
  os << value;
  return os.str();
}

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_SIM_TEXT_H_
