//! The report's grid of configurations: sub-aperture sizes, spots and signals (the full grid or
//! the `quick` preview) and the Monte-Carlo settings they share.

use super::point::OperatingPoint;
use crate::montecarlo::{BgGrid, SimConfig};
use crate::spot::{Sampling, Spot};

/// Sub-aperture sizes of the full grid (px per side).
pub const DEFAULT_SUBAPS_PX: [usize; 6] = [4, 6, 8, 10, 12, 16];
/// Airy diameters of the full grid (first dark ring, px).
pub const DEFAULT_AIRY_DIAMETERS_PX: [f64; 6] = [1.0, 2.0, 4.0, 6.0, 8.0, 10.0];
/// Signals of the full grid (photons per sub-aperture).
pub const DEFAULT_SIGNALS_PHOTONS: [f64; 6] = [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0];
/// Sub-aperture sizes of the quick preview (px per side).
pub const QUICK_SUBAPS_PX: [usize; 3] = [4, 8, 16];
/// Airy diameters of the quick preview (px).
pub const QUICK_AIRY_DIAMETERS_PX: [f64; 2] = [2.0, 6.0];
/// Signals of the quick preview (photons per sub-aperture).
pub const QUICK_SIGNALS_PHOTONS: [f64; 3] = [20.0, 50.0, 500.0];
/// Most iterations per configuration of the quick preview.
pub const QUICK_MAX_ITERS: u64 = 2000;

/// The resolved grid and the Monte-Carlo settings every configuration of a report shares.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    /// Sub-aperture sizes (px per side).
    pub subaps_px: Vec<usize>,
    /// Spots.
    pub spots: Vec<Spot>,
    /// Signals (photons per sub-aperture).
    pub signals_photons: Vec<f64>,
    /// Iterations per configuration.
    pub iters: u64,
    /// Seed of every random stream.
    pub seed: u64,
    /// Spot sampling.
    pub sampling: Sampling,
}

fn airy(diameters_px: &[f64]) -> Vec<Spot> {
    diameters_px
        .iter()
        .map(|&diameter_px| Spot::Airy { diameter_px })
        .collect()
}

/// Fields of the report's options a grid is resolved from.
pub(crate) struct GridChoice<'a> {
    pub subaps_px: Option<&'a [usize]>,
    pub spots: Option<&'a [Spot]>,
    pub signals_photons: Option<&'a [f64]>,
    pub iters: u64,
    pub seed: u64,
    pub sampling: Sampling,
    pub quick: bool,
}

impl Grid {
    /// The grid: each list as given, or (left unset) the full grid's, or with `quick` the
    /// preview's; `quick` also caps the iterations.
    pub fn resolve(c: &GridChoice) -> Grid {
        let quick = c.quick;
        let or = |given: Option<&[usize]>, full: &[usize], preview: &[usize]| -> Vec<usize> {
            given.unwrap_or(if quick { preview } else { full }).to_vec()
        };
        let spots = match c.spots {
            Some(s) => s.to_vec(),
            None if quick => airy(&QUICK_AIRY_DIAMETERS_PX),
            None => airy(&DEFAULT_AIRY_DIAMETERS_PX),
        };
        let signals_photons = match c.signals_photons {
            Some(s) => s.to_vec(),
            None if quick => QUICK_SIGNALS_PHOTONS.to_vec(),
            None => DEFAULT_SIGNALS_PHOTONS.to_vec(),
        };
        Grid {
            subaps_px: or(c.subaps_px, &DEFAULT_SUBAPS_PX, &QUICK_SUBAPS_PX),
            spots,
            signals_photons,
            iters: if quick {
                c.iters.min(QUICK_MAX_ITERS)
            } else {
                c.iters
            },
            seed: c.seed,
            sampling: c.sampling,
        }
    }

    /// The one configuration of this grid's settings at (sub-aperture, spot, signal, QE).
    pub fn config(&self, subap_px: usize, spot: Spot, signal_photons: f64, qe: f64) -> SimConfig {
        SimConfig {
            spot,
            sampling: self.sampling,
            signal_photons,
            qe,
            iters: self.iters,
            seed: self.seed,
            bg_grid: BgGrid::Auto,
            ..SimConfig::paper(subap_px)
        }
    }

    /// Every configuration, sub-aperture major, then spot, then signal, at quantum efficiency `qe`.
    pub fn configs(&self, qe: f64) -> Vec<SimConfig> {
        let mut out = Vec::new();
        for &n in &self.subaps_px {
            for &spot in &self.spots {
                for &signal_photons in &self.signals_photons {
                    out.push(self.config(n, spot, signal_photons, qe));
                }
            }
        }
        out
    }

    /// Whether `p` is one of this grid's configurations.
    pub fn contains(&self, p: &OperatingPoint) -> bool {
        self.subaps_px.contains(&p.subap_px)
            && self.spots.contains(&p.spot)
            && self.signals_photons.contains(&p.signal_photons)
    }

    /// The signals of a comparison at `p`: the grid's, with `p`'s added (ascending) if missing.
    pub fn signals_with(&self, p: &OperatingPoint) -> Vec<f64> {
        let mut s = self.signals_photons.clone();
        if !s.contains(&p.signal_photons) {
            s.push(p.signal_photons);
            s.sort_by(f64::total_cmp);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn choice(quick: bool) -> GridChoice<'static> {
        GridChoice {
            subaps_px: None,
            spots: None,
            signals_photons: None,
            iters: 10_000,
            seed: 7,
            sampling: Sampling::Point,
            quick,
        }
    }

    #[test]
    fn quick_shrinks_only_what_was_left_unset_and_caps_the_iterations() {
        let full = Grid::resolve(&choice(false));
        assert_eq!(full.subaps_px, DEFAULT_SUBAPS_PX);
        assert_eq!(full.spots.len(), 6);
        assert_eq!(full.iters, 10_000);
        let quick = Grid::resolve(&choice(true));
        assert_eq!(quick.subaps_px, QUICK_SUBAPS_PX);
        assert_eq!(quick.spots, airy(&[2.0, 6.0]));
        assert_eq!(quick.signals_photons, QUICK_SIGNALS_PHOTONS);
        assert_eq!(quick.iters, QUICK_MAX_ITERS);
        let given = Grid::resolve(&GridChoice {
            subaps_px: Some(&[6]),
            iters: 100,
            ..choice(true)
        });
        assert_eq!(given.subaps_px, [6]);
        assert_eq!(given.signals_photons, QUICK_SIGNALS_PHOTONS);
        assert_eq!(given.iters, 100);
    }

    #[test]
    fn configs_are_the_product_in_order_with_the_shared_settings() {
        let g = Grid::resolve(&choice(true));
        let c = g.configs(0.7);
        assert_eq!(c.len(), 3 * 2 * 3);
        assert_eq!((c[0].subap_px, c[0].signal_photons), (4, 20.0));
        assert_eq!((c[1].subap_px, c[1].signal_photons), (4, 50.0));
        assert_eq!(c[3].spot, Spot::Airy { diameter_px: 6.0 });
        assert_eq!(c[6].subap_px, 8);
        for cfg in &c {
            assert_eq!((cfg.qe, cfg.seed, cfg.iters), (0.7, 7, QUICK_MAX_ITERS));
            assert_eq!(cfg.sampling, Sampling::Point);
            assert_eq!(cfg.position_half_range_px, 0.5);
        }
    }

    #[test]
    fn the_operating_point_is_looked_up_not_moved_into_the_grid() {
        let g = Grid::resolve(&choice(true));
        let default = OperatingPoint::default();
        assert!(g.contains(&default));
        assert_eq!(g.signals_with(&default), QUICK_SIGNALS_PHOTONS);
        let off = OperatingPoint {
            subap_px: 6,
            signal_photons: 70.0,
            ..default
        };
        assert!(!g.contains(&off));
        assert!(!g.contains(&OperatingPoint {
            spot: Spot::Airy { diameter_px: 3.0 },
            ..default
        }));
        assert_eq!(g.signals_with(&off), [20.0, 50.0, 70.0, 500.0]);
    }
}
