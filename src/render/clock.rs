//! The seconds a trial's launches cost, as the strategy trial (render/strategy.rs) compares
//! candidates by them: wall seconds, and where the device's threads run in this process (a CPU
//! device: PoCL's pthread driver), the process's CPU seconds too.
//!
//! Why CPU seconds: a CPU's trial launches last 1 to 40 ms, and their wall time depends on how
//! the few work-groups of a trial's lattice fell to the device's threads and on what else the
//! machine ran meanwhile, while the work they did does not. PoCL on 2 cores, one candidate's
//! trial against another's with the same seed and the same pixels (the same work), twelve
//! trials of each scene at 160x120 (BENCHMARKS.md): the ratio of light sampling on to off with
//! roulette below 0.3 read 1.641 ± 0.142 (one standard deviation) in wall seconds and 1.545 ±
//! 0.033 in CPU seconds on ceiling_room, 1.577 ± 0.073 and 1.572 ± 0.018 on meshes. Work done
//! elsewhere (another process, a stolen virtual CPU) is not charged to this process; the
//! threads' waits for each other are not charged either.

use std::time::Instant;

/// Seconds spent in one launch or a run of them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spent {
    /// Wall seconds.
    pub wall: f64,
    /// This process's CPU seconds, all its threads together (NaN where unknown).
    pub cpu: f64,
}

impl std::ops::AddAssign for Spent {
    fn add_assign(&mut self, other: Spent) {
        self.wall += other.wall;
        self.cpu += other.cpu;
    }
}

/// The CPU seconds this process's threads have used, all together: POSIX
/// `CLOCK_PROCESS_CPUTIME_ID` (nanosecond resolution on Linux). NaN where the clock fails.
pub fn process_cpu_seconds() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    if status == 0 {
        t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

/// Runs `f` and returns its result with the wall and CPU seconds it took.
pub fn measure<T>(f: impl FnOnce() -> T) -> (T, Spent) {
    let (cpu, wall) = (process_cpu_seconds(), Instant::now());
    let out = f();
    let spent = Spent {
        wall: wall.elapsed().as_secs_f64(),
        cpu: process_cpu_seconds() - cpu,
    };
    (out, spent)
}

/// A round's CPU seconds count as the device's work only where they are at least this share
/// of its wall seconds: the device's threads ran in this process and were busy. A device that
/// runs elsewhere (a GPU, a remote device) leaves this process asleep in its waits.
const IN_PROCESS_SHARE: f64 = 0.5;

/// The seconds that compare a trial round's candidates, part by part (`spent[k][p]`: candidate
/// k's seconds on part p, with what else the part carries, its samples), for
/// [`super::strategy::robust_seconds`]: on a CPU device (`cpu_device`) whose round ran on this
/// process's threads, the CPU seconds, scaled so that the round's total stays its wall seconds
/// (a candidate's seconds a sample remain what a render of it takes, which time-limited renders
/// size themselves by); elsewhere the wall seconds.
pub fn comparable<T: Copy>(spent: &[Vec<(Spent, T)>], cpu_device: bool) -> Vec<Vec<(f64, T)>> {
    let all = || spent.iter().flatten().map(|&(s, _)| s);
    let total = all().fold(Spent::default(), |mut a, s| {
        a += s;
        a
    });
    let in_process =
        cpu_device && all().all(|s| s.cpu > 0.0) && total.cpu >= IN_PROCESS_SHARE * total.wall;
    let seconds = |s: Spent| {
        if in_process {
            s.cpu * total.wall / total.cpu
        } else {
            s.wall
        }
    };
    spent
        .iter()
        .map(|parts| parts.iter().map(|&(s, t)| (seconds(s), t)).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spent(wall: f64, cpu: f64) -> Spent {
        Spent { wall, cpu }
    }

    #[test]
    fn the_process_clock_counts_this_process_s_work() {
        // Busy until the clock has counted 30 ms of work: a clock that failed (NaN) or stands
        // still never gets there.
        let (x, worked) = measure(|| {
            let (start, cpu) = (Instant::now(), process_cpu_seconds());
            let mut x = 0u64;
            while process_cpu_seconds() - cpu < 0.03 && start.elapsed().as_secs_f64() < 10.0 {
                for _ in 0..1000 {
                    x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                }
            }
            x
        });
        assert!(worked.cpu >= 0.03 && worked.wall < 10.0, "{worked:?} ({x})");
    }

    #[test]
    fn a_cpu_device_is_compared_by_its_work_at_the_round_s_wall_time() {
        let seconds = |round: Vec<Vec<(f64, u32)>>| -> Vec<f64> {
            round.into_iter().flatten().map(|(s, _)| s).collect()
        };
        // Two candidates on two parts of 3 samples; the first's second part slowed in wall time
        // alone (something else ran), so the CPU seconds keep their 1:2 ratio.
        let round = [
            vec![(spent(0.10, 0.18), 3), (spent(0.25, 0.18), 3)],
            vec![(spent(0.20, 0.36), 3), (spent(0.20, 0.36), 3)],
        ];
        let cpu = comparable(&round, true);
        assert!(cpu.iter().flatten().all(|&(_, n)| n == 3));
        let scale = 0.75 / 1.08;
        let expected = [0.18 * scale, 0.18 * scale, 0.36 * scale, 0.36 * scale];
        let cpu = seconds(cpu);
        assert!(
            cpu.iter()
                .zip(expected)
                .all(|(got, want)| (got - want).abs() < 1e-12),
            "{cpu:?}"
        );
        assert!((cpu.iter().sum::<f64>() - 0.75).abs() < 1e-12);
        // A GPU, or a CPU device whose threads did not run here: wall seconds.
        let walls = vec![0.10, 0.25, 0.20, 0.20];
        assert_eq!(seconds(comparable(&round, false)), walls);
        let elsewhere = [
            vec![(spent(0.10, 0.01), 3), (spent(0.25, 0.01), 3)],
            vec![(spent(0.20, 0.02), 3), (spent(0.20, 0.01), 3)],
        ];
        assert_eq!(seconds(comparable(&elsewhere, true)), walls);
        // A clock that failed (NaN) or read nothing: wall seconds.
        let failed = [vec![(spent(0.1, f64::NAN), 3)], vec![(spent(0.2, 0.3), 3)]];
        assert_eq!(seconds(comparable(&failed, true)), [0.1, 0.2]);
    }
}
