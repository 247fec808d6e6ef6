# Finds Debian's ROS 1 bag libraries (librosbag-storage-dev, libroscpp-core-dev, the message
# packages libsensor-msgs-dev, libnav-msgs-dev, libgeometry-msgs-dev, libtf2-msgs-dev) without
# catkin. Debian 12's rosbag_storage.pc requires a pluginlib.pc that does not exist, and
# rosbag/bag.h includes pluginlib and class_loader headers that live one folder deeper than
# usual, so the folders are looked up here by hand.
#
# Sets HETSLAM_ROSBAG_FOUND, HETSLAM_ROSBAG_INCLUDE_DIRS, HETSLAM_ROSBAG_LIBRARIES and, when
# something is missing, HETSLAM_ROSBAG_MISSING (the names not found).
set(HETSLAM_ROSBAG_MISSING "")
set(HETSLAM_ROSBAG_INCLUDE_DIRS "")
set(HETSLAM_ROSBAG_LIBRARIES "")

# header -> the folder that must be on the include path for it.
foreach(header IN ITEMS rosbag/bag.h roslz4/lz4s.h bzlib.h ros/serialization.h ros/time.h sensor_msgs/LaserScan.h sensor_msgs/Imu.h
                        sensor_msgs/Image.h nav_msgs/Odometry.h nav_msgs/Path.h geometry_msgs/Twist.h
                        geometry_msgs/TwistStamped.h geometry_msgs/PoseStamped.h tf2_msgs/TFMessage.h)
  string(MAKE_C_IDENTIFIER "HETSLAM_ROSBAG_H_${header}" var)
  find_path(${var} ${header})
  if(${var})
    list(APPEND HETSLAM_ROSBAG_INCLUDE_DIRS ${${var}})
  else()
    list(APPEND HETSLAM_ROSBAG_MISSING ${header})
  endif()
endforeach()
foreach(header IN ITEMS pluginlib/class_loader.hpp class_loader/multi_library_class_loader.hpp
                        rcpputils/filesystem_helper.hpp rcutils/allocator.h ament_index_cpp/get_package_prefix.hpp)
  string(MAKE_C_IDENTIFIER "HETSLAM_ROSBAG_H_${header}" var)
  string(REGEX REPLACE "/.*" "" package ${header})
  find_path(${var} ${header} PATH_SUFFIXES ${package})
  if(${var})
    list(APPEND HETSLAM_ROSBAG_INCLUDE_DIRS ${${var}})
  else()
    list(APPEND HETSLAM_ROSBAG_MISSING ${header})
  endif()
endforeach()
list(REMOVE_DUPLICATES HETSLAM_ROSBAG_INCLUDE_DIRS)

# roslz4 and bz2: core/ros_bag_plugin.cc decompresses chunks itself to check their records. These
# libraries are linked by the plugin alone (core/CMakeLists.txt), never by hetslam_core.
foreach(library IN ITEMS rosbag_storage roscpp_serialization rostime cpp_common roslz4 bz2 console_bridge)
  string(MAKE_C_IDENTIFIER "HETSLAM_ROSBAG_LIB_${library}" var)
  find_library(${var} ${library})
  if(${var})
    list(APPEND HETSLAM_ROSBAG_LIBRARIES ${${var}})
  else()
    list(APPEND HETSLAM_ROSBAG_MISSING lib${library})
  endif()
endforeach()

if(HETSLAM_ROSBAG_MISSING STREQUAL "")
  set(HETSLAM_ROSBAG_FOUND TRUE)
else()
  set(HETSLAM_ROSBAG_FOUND FALSE)
endif()
