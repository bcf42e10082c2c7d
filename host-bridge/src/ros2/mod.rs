//! ROS 2: the `sensor_msgs/msg/LaserScan` message ([`laser_scan`]) and
//! bags read as scan input ([`bag_in`]: rosbag2 with MCAP storage, or a
//! single `.mcap` file).

pub mod bag_in;
pub mod cdr;
pub mod laser_scan;
pub mod mcap_out;
pub mod messages;
pub mod rosbag2_out;
