//! The in-process sampling harness: warm up, then time batches of calls and take the median
//! time per call.

use std::time::{Duration, Instant};

/// Median of a non-empty slice (sorted in place).
pub fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// The fewest batches a cell is timed in (a cell timed in `P` passes takes `MIN_BATCHES / P`
/// rounded up in each).
pub const MIN_BATCHES: usize = 11;

/// Per-call times (µs) of timed batches of `batch` calls.
#[derive(Clone, Debug)]
pub struct Samples {
    pub times_us: Vec<f64>,
}

/// Times `call` for about `budget`: a warm-up of at least 3 calls and a tenth of the budget
/// estimates the cost; batches are sized to last ≥ 200 µs (so the clock's resolution does not
/// matter); between `min_batches` and 201 batches are timed.
pub fn sample<E>(
    budget: Duration,
    min_batches: usize,
    mut call: impl FnMut() -> Result<(), E>,
) -> Result<Samples, E> {
    let warm_until = Instant::now() + budget / 10;
    let mut calls = 0u32;
    let start = Instant::now();
    while calls < 3 || Instant::now() < warm_until {
        call()?;
        calls += 1;
    }
    let per_call = start.elapsed().as_secs_f64() / f64::from(calls);
    let batch = ((200e-6 / per_call).ceil() as usize).max(1);
    let samples = ((budget.as_secs_f64() * 0.9 / (per_call * batch as f64)) as usize)
        .clamp(min_batches.clamp(1, 201), 201);
    let mut times_us = Vec::with_capacity(samples);
    for _ in 0..samples {
        let t = Instant::now();
        for _ in 0..batch {
            call()?;
        }
        times_us.push(t.elapsed().as_secs_f64() * 1e6 / batch as f64);
    }
    Ok(Samples { times_us })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    }

    #[test]
    fn sample_measures_a_sleep() {
        let mut s = sample(Duration::from_millis(30), MIN_BATCHES, || {
            std::thread::sleep(Duration::from_micros(300));
            Ok::<(), ()>(())
        })
        .unwrap();
        assert!(s.times_us.len() >= MIN_BATCHES);
        let t = median(&mut s.times_us);
        assert!((300.0..5000.0).contains(&t), "{t}");
    }

    #[test]
    fn sample_respects_its_minimum_batches() {
        // A 300 µs call in a 1 ms budget fits ~3 batches; the minimum asks for 5.
        let s = sample(Duration::from_millis(1), 5, || {
            std::thread::sleep(Duration::from_micros(300));
            Ok::<(), ()>(())
        })
        .unwrap();
        assert_eq!(s.times_us.len(), 5);
        assert!(s.times_us.iter().all(|&t| t >= 300.0), "{s:?}");
    }
}
