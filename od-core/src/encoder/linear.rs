//! The linear wire-actuated encoders (SGH10, SGH50): the position pipeline from the sensor's
//! wire extension to the position value, and the device behaviour both manuals share.
