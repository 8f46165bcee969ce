//! The random-telegraph (RTS) chain of a synthetic pixel: a Markov chain over two or three
//! levels with given occupancies and mean dwell times, started from its stationary
//! distribution.
//!
//! Per frame a pixel in level i stays with probability 1 - 1/D_i (so its runs are geometric
//! with mean D_i frames) and otherwise jumps. Stationarity needs the flux out of each level,
//! f_i = pi_i / D_i, to come back in: with two levels f_1 = f_2 (the occupancies follow from
//! the dwell times, pi_i = D_i / (D_1 + D_2)); with three, the chain is reversible with flows
//! w_ij = (f_i + f_j - f_k) / 2 between levels i and j (k the third), which needs each flux
//! at most the sum of the other two. A jump from i goes to j with probability w_ij / f_i.

use rand::RngExt;

use crate::error::{Error, Result};
use crate::rng::SimRng;

/// Relative tolerance of the two-level balance pi_1 / D_1 = pi_2 / D_2.
const BALANCE_TOL: f64 = 1e-6;

/// A stationary two- or three-level Markov chain.
#[derive(Clone, Debug, PartialEq)]
pub struct RtsChain {
    occupancy: Vec<f64>,
    dwell: Vec<f64>,
    /// Per level: probability of leaving per frame, and the cumulative probabilities of the
    /// level jumped to.
    leave: Vec<f64>,
    jump_cdf: Vec<Vec<f64>>,
}

impl RtsChain {
    /// The chain with mean dwell times `dwell_frames` (>= 1 each, two or three levels) and
    /// occupancies `occupancy` (sum 1; None: proportional to the dwell times, equal fluxes).
    pub fn new(dwell_frames: &[f64], occupancy: Option<&[f64]>) -> Result<RtsChain> {
        let k = dwell_frames.len();
        if !(2..=3).contains(&k) {
            return Err(Error::invalid(
                "rts_dwell_frames",
                format!("{k} values: give 2 or 3 (one mean dwell time per level)"),
            ));
        }
        if let Some(d) = dwell_frames.iter().find(|d| !(**d >= 1.0 && d.is_finite())) {
            return Err(Error::invalid(
                "rts_dwell_frames",
                format!("{d} must be finite and >= 1 frame"),
            ));
        }
        let total: f64 = dwell_frames.iter().sum();
        let occ: Vec<f64> = match occupancy {
            None => dwell_frames.iter().map(|d| d / total).collect(),
            Some(o) => {
                let sum: f64 = o.iter().sum();
                if o.len() != k
                    || o.iter().any(|p| p.is_nan() || *p <= 0.0)
                    || (sum - 1.0).abs() > 1e-9
                {
                    return Err(Error::invalid(
                        "rts_occupancy",
                        format!(
                            "{o:?}: give {k} occupancies > 0 summing to 1, one per `rts_dwell_frames` value"
                        ),
                    ));
                }
                o.to_vec()
            }
        };
        let f: Vec<f64> = occ.iter().zip(dwell_frames).map(|(p, d)| p / d).collect();
        let flows = if k == 2 {
            if (f[0] - f[1]).abs() > BALANCE_TOL * f[0].max(f[1]) {
                return Err(Error::invalid(
                    "rts_occupancy",
                    format!(
                        "with two levels the occupancies follow from `rts_dwell_frames`: {:.6}, {:.6}",
                        dwell_frames[0] / total,
                        dwell_frames[1] / total
                    ),
                ));
            }
            vec![vec![0.0, f[0]], vec![f[1], 0.0]]
        } else {
            let w = |i: usize, j: usize| (f[i] + f[j] - f[3 - i - j]) / 2.0;
            if (0..3).any(|i| f[i] > f[(i + 1) % 3] + f[(i + 2) % 3]) {
                return Err(Error::invalid(
                    "rts_occupancy",
                    "no stationary three-level chain has these: each occupancy / dwell time must be at most the sum of the other two",
                ));
            }
            (0..3)
                .map(|i| (0..3).map(|j| if i == j { 0.0 } else { w(i, j) }).collect())
                .collect()
        };
        let jump_cdf = flows
            .iter()
            .zip(&f)
            .map(|(row, fi): (&Vec<f64>, &f64)| {
                let mut acc = 0.0;
                row.iter()
                    .map(|w| {
                        acc += w / fi;
                        acc
                    })
                    .collect()
            })
            .collect();
        Ok(RtsChain {
            leave: dwell_frames.iter().map(|d| 1.0 / d).collect(),
            occupancy: occ,
            dwell: dwell_frames.to_vec(),
            jump_cdf,
        })
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.dwell.len()
    }

    /// Stationary occupancy of each level.
    pub fn occupancy(&self) -> &[f64] {
        &self.occupancy
    }

    /// Mean dwell time of each level (frames).
    pub fn dwell_frames(&self) -> &[f64] {
        &self.dwell
    }

    /// A level drawn from the stationary distribution.
    pub fn start(&self, rng: &mut SimRng) -> u8 {
        let u: f64 = rng.random();
        let mut acc = 0.0;
        for (i, p) in self.occupancy.iter().enumerate() {
            acc += p;
            if u < acc {
                return i as u8;
            }
        }
        (self.levels() - 1) as u8
    }

    /// The level one frame after `level`.
    pub fn step(&self, level: u8, rng: &mut SimRng) -> u8 {
        let i = level as usize;
        let u: f64 = rng.random();
        if u >= self.leave[i] {
            return level;
        }
        // The same uniform, rescaled, picks the destination (u / leave is uniform on [0, 1)).
        let v = u / self.leave[i];
        let cdf = &self.jump_cdf[i];
        let j = cdf.iter().position(|c| v < *c).unwrap_or_else(|| {
            // Round-off at the top: the last level other than i.
            (0..cdf.len()).rev().find(|j| *j != i).expect("two levels")
        });
        j as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;

    /// Occupancy and mean run length of each level over `t` frames of `c`.
    fn simulate(c: &RtsChain, t: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut rng = stream(seed, 0, 0x7e1e);
        let mut s = c.start(&mut rng);
        let k = c.levels();
        let (mut time, mut runs) = (vec![0.0; k], vec![0.0; k]);
        runs[s as usize] += 1.0;
        for _ in 0..t {
            time[s as usize] += 1.0;
            let n = c.step(s, &mut rng);
            if n != s {
                runs[n as usize] += 1.0;
            }
            s = n;
        }
        let occ = time.iter().map(|x| x / t as f64).collect();
        let dwell = time.iter().zip(&runs).map(|(a, b)| a / b).collect();
        (occ, dwell)
    }

    #[test]
    fn a_long_chain_has_the_stated_occupancies_and_dwell_times() {
        // Three levels, 400,000 frames: every level is entered > 10,000 times, so the mean
        // run length has a relative SE below sqrt(1 / 10,000) = 1 %; occupancies have an SE
        // below 0.2 % (runs of ~20 frames); bounds at 4 SE.
        let c = RtsChain::new(&[20.0, 8.0, 12.0], Some(&[0.5, 0.2, 0.3])).unwrap();
        let (occ, dwell) = simulate(&c, 400_000, 1);
        for i in 0..3 {
            assert!((occ[i] - c.occupancy()[i]).abs() < 0.008, "{occ:?}");
            assert!(
                (dwell[i] / c.dwell_frames()[i] - 1.0).abs() < 0.04,
                "{dwell:?}"
            );
        }
        // Two levels: occupancy from the dwell times.
        let c = RtsChain::new(&[30.0, 10.0], None).unwrap();
        assert_eq!(c.occupancy(), &[0.75, 0.25]);
        let (occ, dwell) = simulate(&c, 400_000, 2);
        assert!((occ[0] - 0.75).abs() < 0.01, "{occ:?}");
        assert!((dwell[1] / 10.0 - 1.0).abs() < 0.04, "{dwell:?}");
    }

    #[test]
    fn impossible_chains_are_refused_naming_the_field() {
        let field = |r: Result<RtsChain>| match r {
            Err(Error::Usage { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(RtsChain::new(&[5.0], None)), "rts_dwell_frames");
        assert_eq!(field(RtsChain::new(&[0.5, 3.0], None)), "rts_dwell_frames");
        assert_eq!(
            field(RtsChain::new(&[10.0, 10.0], Some(&[0.9, 0.1]))),
            "rts_occupancy"
        );
        assert_eq!(
            field(RtsChain::new(&[1.0, 50.0, 50.0], Some(&[0.9, 0.05, 0.05]))),
            "rts_occupancy"
        );
        assert!(RtsChain::new(&[10.0, 10.0], Some(&[0.5, 0.5])).is_ok());
    }
}
