//! One `tf2_msgs/TFMessage`: the first byte picks the encoding (ROS 1 or CDR), the rest goes
//! to `decode_tf_message`.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::mcap::{decode_tf_message, Encoding};

fuzz_target!(|data: &[u8]| {
    let Some((&first, msg)) = data.split_first() else {
        return;
    };
    let encoding = if first & 1 == 0 {
        Encoding::Ros1
    } else {
        Encoding::Cdr
    };
    let _ = decode_tf_message(msg, encoding);
});
