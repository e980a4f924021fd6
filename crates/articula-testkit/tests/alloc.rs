//! The counting allocator counts what the closure allocates, on this thread only.

use articula_testkit::{count_allocations, CountingAllocator};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn the_counter_counts() {
    let n = count_allocations(|| {
        let v: Vec<u64> = Vec::with_capacity(10);
        std::hint::black_box(v);
    });
    assert_eq!(n, 1);
    assert_eq!(count_allocations(|| ()), 0);
    // A reallocation counts too: 1 + growths of a vector pushed past its capacity.
    let n = count_allocations(|| {
        let mut v: Vec<u64> = Vec::with_capacity(1);
        for i in 0..5 {
            v.push(i);
        }
        std::hint::black_box(v);
    });
    assert!(n >= 2, "{n}");
}

#[test]
fn other_threads_do_not_count() {
    // A first spawn may set up the runtime's lazily initialised state: not counted.
    std::thread::scope(|s| {
        s.spawn(|| ());
    });
    let n = count_allocations(|| {
        std::thread::scope(|s| {
            s.spawn(|| std::hint::black_box(vec![0u8; 64]));
        });
    });
    // The spawn itself allocates on this thread; the 64 bytes on the other one do not count.
    let spawn_only = count_allocations(|| {
        std::thread::scope(|s| {
            s.spawn(|| ());
        });
    });
    assert_eq!(n, spawn_only);
}

#[test]
fn nested_counts_add_up() {
    let mut inner = 0;
    let outer = count_allocations(|| {
        std::hint::black_box(Box::new(1u64));
        inner = count_allocations(|| {
            std::hint::black_box(Box::new(2u64));
        });
    });
    assert_eq!((inner, outer), (1, 2));
}
