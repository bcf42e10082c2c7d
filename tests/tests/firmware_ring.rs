//! The firmware's byte queue between an interrupt and the main loop
//! (`firmware/src/ring.rs`), compiled for the host: against a model queue
//! under random operations, and across two threads, a producer and a
//! consumer, every byte in order. The firmware itself is a `thumbv7em`
//! build; the ring uses only `core`, so the same source runs here.

#[path = "../../firmware/src/ring.rs"]
mod ring;

use std::collections::VecDeque;

use proptest::prelude::*;
use ring::Ring;

/// Slots of the rings tested (holds one less byte).
const SLOTS: usize = 8;

proptest! {
    /// Any sequence of enqueues and dequeues gives what a bounded FIFO
    /// of `SLOTS − 1` bytes gives, with the same length, room and readiness.
    #[test]
    fn ring_is_a_bounded_fifo(ops in proptest::collection::vec(proptest::option::of(any::<u8>()), 0..200)) {
        let mut storage = Ring::<SLOTS>::new();
        let (mut producer, mut consumer) = storage.split();
        let mut model: VecDeque<u8> = VecDeque::new();
        prop_assert_eq!(producer.capacity(), SLOTS - 1);
        prop_assert_eq!(consumer.capacity(), SLOTS - 1);
        for op in ops {
            match op {
                Some(byte) => {
                    let fits = model.len() < SLOTS - 1;
                    prop_assert_eq!(producer.ready(), fits);
                    if fits {
                        prop_assert_eq!(producer.enqueue(byte), Ok(()));
                        model.push_back(byte);
                    } else {
                        prop_assert_eq!(producer.enqueue(byte), Err(byte));
                    }
                }
                None => {
                    prop_assert_eq!(consumer.ready(), !model.is_empty());
                    prop_assert_eq!(consumer.dequeue(), model.pop_front());
                }
            }
            prop_assert_eq!(producer.len(), model.len());
            prop_assert_eq!(consumer.len(), model.len());
            prop_assert_eq!(producer.is_empty(), model.is_empty());
        }
    }
}

/// A producer thread and a consumer thread, as the interrupt and the loop:
/// 200 000 bytes through a 16-slot ring arrive complete and in order.
#[test]
fn bytes_cross_threads_in_order() {
    const BYTES: u32 = 200_000;
    let storage: &'static mut Ring<16> = Box::leak(Box::new(Ring::new()));
    let (mut producer, mut consumer) = storage.split();
    let writer = std::thread::spawn(move || {
        for k in 0..BYTES {
            let mut byte = (k % 251) as u8;
            while let Err(back) = producer.enqueue(byte) {
                byte = back;
                std::thread::yield_now();
            }
        }
    });
    let mut k = 0u32;
    while k < BYTES {
        match consumer.dequeue() {
            Some(byte) => {
                assert_eq!(byte, (k % 251) as u8, "byte {k}");
                k += 1;
            }
            None => std::thread::yield_now(),
        }
    }
    writer.join().expect("the producer thread");
    assert_eq!(consumer.dequeue(), None);
}
