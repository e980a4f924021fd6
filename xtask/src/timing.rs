//! The in-process sampling harness: warm up, then time batches of calls and take the median
//! time per call.

use std::time::{Duration, Instant};

/// A timing: median time per call over `samples` batches of `batch` calls.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    pub median_us: f64,
    pub samples: usize,
    pub batch: usize,
}

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

/// The fewest batches [`time`] times (a cell timed in `P` passes takes `MIN_BATCHES / P`
/// rounded up in each).
pub const MIN_BATCHES: usize = 11;

/// Per-call times (µs) of timed batches of `batch` calls.
#[derive(Clone, Debug)]
pub struct Samples {
    pub times_us: Vec<f64>,
    pub batch: usize,
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
    Ok(Samples { times_us, batch })
}

/// [`sample`] with at least [`MIN_BATCHES`] batches, and their median time per call.
pub fn time<E>(budget: Duration, call: impl FnMut() -> Result<(), E>) -> Result<Timing, E> {
    let mut s = sample(budget, MIN_BATCHES, call)?;
    Ok(Timing {
        median_us: median(&mut s.times_us),
        samples: s.times_us.len(),
        batch: s.batch,
    })
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
    fn time_measures_a_sleep() {
        let t = time(Duration::from_millis(30), || {
            std::thread::sleep(Duration::from_micros(300));
            Ok::<(), ()>(())
        })
        .unwrap();
        assert!(t.median_us >= 300.0 && t.median_us < 5000.0, "{t:?}");
        assert!(t.samples >= 11);
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
        assert_eq!(s.batch, 1);
        assert!(s.times_us.iter().all(|&t| t >= 300.0), "{s:?}");
    }
}
