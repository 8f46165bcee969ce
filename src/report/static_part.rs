//! The report's section on what a closed loop sees: the random and static parts of the
//! centroid error of the real-noise camera, per configuration of the effective-noise table.
//!
//! R mixes the two. The random part (the rms of the error about its mean, the slope noise a
//! loop averages) has its own effective sigma, `sigma_random_e`; the static part (the mean
//! error vector, a slope offset that a fixed noise map causes at that flux) is what reference
//! slopes measured with the camera at the operating flux remove.

use super::html::{fmt_effective, num};
use crate::effective::{EffectiveParts, EffectiveRecord};
use crate::output::html_escape as esc;
use std::fmt::Write as _;

/// `value ± se` with `decimals`, or a dash where either is not finite.
fn pm(v: f64, se: f64, decimals: usize) -> String {
    if v.is_finite() && se.is_finite() {
        format!("{} ± {}", num(v, decimals), num(se, decimals))
    } else {
        "–".into()
    }
}

/// The random sigma as the page shows it: value ± SE, marked where extrapolated.
fn sigma_random(p: &EffectiveParts) -> String {
    let v = pm(p.sigma_random_e, p.sigma_random_se_e, 2);
    if p.sigma_random_extrapolated && p.sigma_random_e.is_finite() {
        format!("{v} <span class=\"note\">(extrapolated)</span>")
    } else {
        v
    }
}

/// The section's HTML for the table's records `effective` (every model of the table; empty
/// when none carries the parts).
pub(super) fn html_section(effective: &[EffectiveRecord]) -> String {
    let rows: Vec<&EffectiveRecord> = effective
        .iter()
        .filter(|r| r.effective.parts.random_rms_px.is_finite())
        .collect();
    if rows.is_empty() {
        return String::new();
    }
    let mut h = String::new();
    h.push_str("<h2>Random and static parts: what a closed loop sees</h2>");
    h.push_str("<p>R mixes two parts that a closed loop treats differently. The <b>random part</b> is the frame-to-frame scatter of the centroid about its mean (rms, px): the slope noise the loop averages; the constant Gaussian read noise that gives a uniform camera the same rms error is <b>σ<sub>random</sub></b>, the read noise to simulate when the static part is calibrated out. The <b>static part</b> is the mean centroid offset (px) that a <i>fixed</i> noise map causes at this flux: its noisy pixels pull the clipped centroid the same way every frame, and a loop builds that offset into a static aberration. <b>Reference slopes measured with the camera at the operating flux remove the static part</b>; reference slopes taken without noise (or at another flux) leave it in the loop, as large as the offset below for each sub-aperture.</p>");
    h.push_str("<p class=\"note\">The models here draw a new window of the map (or new pixel sigmas) every frame, so their static part averages out: it is the spread over frames, not one sub-aperture's offset. A real sub-aperture reads the same pixels every frame: its own static offset and σ<sub>random</sub> are mapped per sub-aperture by <code>detnoise subaps</code> (static_x_px.fits, static_y_px.fits, sigma_random_e.fits); a static offset marked <i>resolved</i> is at least 3 times its standard error, otherwise it is consistent with zero.</p>");
    let _ = write!(h, "<details><summary>Every configuration: {} rows</summary><table><tr><th>model</th><th>centroider</th><th>subap</th><th>spot</th><th>signal</th><th>R (px)</th><th>random rms (px)</th><th>σ<sub>random</sub> (e⁻)</th><th>σ<sub>eff</sub> (e⁻)</th><th>static offset (px)</th><th>static (x, y) (px)</th></tr>", rows.len());
    for r in rows {
        let (e, c, p) = (&r.effective, &r.config, &r.effective.parts);
        let resolved = if p.static_resolved { " resolved" } else { "" };
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}×{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}{}</td><td>({}, {})</td></tr>",
            esc(&r.model),
            esc(&r.centroider),
            c.subap_px,
            c.subap_px,
            esc(&c.spot.label()),
            c.signal_photons,
            pm(e.r_px, e.r_se_px, 4),
            num(p.random_rms_px, 4),
            sigma_random(p),
            fmt_effective(e.sigma_eff_e, e.sigma_eff_se_e, e.status),
            pm(p.static_px, p.static_se_px, 4),
            resolved,
            num(p.static_x_px, 4),
            num(p.static_y_px, 4),
        );
    }
    h.push_str("</table></details>");
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effective::{Effective, Status};
    use crate::montecarlo::SimConfig;

    #[test]
    fn the_section_says_what_removes_the_static_part_and_lists_each_configuration() {
        let e = Effective {
            sigma_eff_e: 1.5,
            sigma_eff_se_e: 0.02,
            sigma_cog_equiv_e: 1.5,
            sigma_cog_equiv_se_e: 0.02,
            target_se_e: None,
            iters: 1000,
            r_px: 0.3,
            r_se_px: 0.003,
            b_opt_e: 1.0,
            param_name: None,
            param_opt: None,
            sigma_grid_e: vec![],
            r_const_px: vec![],
            status: Status::Ok,
            parts: EffectiveParts {
                sigma_random_e: 1.25,
                sigma_random_se_e: 0.03,
                sigma_random_extrapolated: true,
                random_rms_px: 0.33,
                static_x_px: 0.1,
                static_y_px: -0.05,
                static_px: 0.112,
                static_se_px: 0.004,
                static_resolved: true,
            },
        };
        let cfg = SimConfig::paper(8);
        let with = EffectiveRecord::new("scmos-map".into(), &cfg, &e);
        let h = html_section(std::slice::from_ref(&with));
        assert!(h.contains("Reference slopes measured with the camera at the operating flux remove the static part"));
        assert!(
            h.contains("1.25 ± 0.03") && h.contains("(extrapolated)") && h.contains(" resolved")
        );
        let without = Effective {
            parts: EffectiveParts::default(),
            ..e
        };
        let none = EffectiveRecord::new("scmos-map".into(), &cfg, &without);
        assert_eq!(html_section(&[none]), "");
    }
}
