use super::*;
use crate::calib::{Map, Unit};
use crate::detector::ScmosConstant;
use crate::effective::{effective_sigma, EffectiveParts, Precision, Status};
use crate::montecarlo::SimConfig;
use crate::progress::{Recorder, Silent};
use crate::Error;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering::Relaxed;

fn field(e: Error) -> String {
    match e {
        Error::Usage { field, .. } => field,
        other => panic!("expected a usage error, got {other:?}"),
    }
}

fn grid(text: &str) -> Geometry {
    Geometry {
        grid: GridSpec::parse(text).unwrap(),
        mask: None,
    }
}

#[test]
fn grids_parse_with_defaults_and_refuse_bad_text() {
    let g = GridSpec::parse("16").unwrap();
    assert_eq!((g.size_px, g.pitch_px, g.x0_px, g.y0_px), (16, 16, 0, 0));
    let g = GridSpec::parse(" 16, 18 ,4,2").unwrap();
    assert_eq!((g.size_px, g.pitch_px, g.x0_px, g.y0_px), (16, 18, 4, 2));
    assert_eq!(GridSpec::parse("8,10").unwrap().pitch_px, 10);
    assert_eq!(GridSpec::parse(&g.text()).unwrap(), g);
    for bad in ["", "x", "16,8", "1", "200", "16,16,4", "16,16,4,4,4", "-16"] {
        let e = GridSpec::parse(bad).unwrap_err();
        let msg = e.to_string();
        assert_eq!(field(e), "subap_grid", "{bad:?}");
        assert!(msg.contains("SIZE[,PITCH[,X0,Y0]]"), "{msg}");
    }
}

#[test]
fn layouts_follow_size_pitch_origin_and_fit() {
    // 64x64 px, 16 px: 4x4 sub-apertures, row-major.
    let l = grid("16").layout(64, 64).unwrap();
    assert_eq!((l.grid_rows, l.grid_cols, l.subaps.len()), (4, 4, 16));
    let s = l.subaps[6];
    assert_eq!(
        (s.index, s.grid_row, s.grid_col, s.y0_px, s.x0_px),
        (6, 1, 2, 16, 32)
    );
    // Pitch 18 from (4, 2): columns at 4, 22, 40 (58 + 16 > 64), rows at 2, 20, 38 (56 + 16 >
    // 70).
    let l = grid("16,18,4,2").layout(70, 64).unwrap();
    assert_eq!((l.grid_rows, l.grid_cols), (3, 3));
    let last = l.subaps[8];
    assert_eq!((last.y0_px, last.x0_px), (38, 40));
    // A partial fit: 40x40 px holds 2x2 of 16 px; nothing is left over to state without a mask.
    let l = grid("16").layout(40, 40).unwrap();
    assert_eq!(l.subaps.len(), 4);
    // Nothing fits: an error of the grid naming the map's size.
    let e = grid("16,16,50,0").layout(64, 64).unwrap_err();
    assert!(e.to_string().contains("64x64 px map"), "{e}");
    assert_eq!(field(e), "subap_grid");
    assert_eq!(field(grid("32").layout(16, 64).unwrap_err()), "subap_grid");
}

#[test]
fn grid_arithmetic_is_checked_and_never_wraps() {
    // The origin of the issue: 16 px from column 2^64 - 16 would end at 2^64 (wraps to 0).
    let e = GridSpec::parse("16,16,18446744073709551600,0").unwrap_err();
    assert!(e.to_string().contains("X0 = 18446744073709551600"), "{e}");
    assert_eq!(field(e), "subap_grid");
    let e = GridSpec::parse("16,16,0,18446744073709551615").unwrap_err();
    assert!(e.to_string().contains("Y0"), "{e}");
    // An origin that is a number but beyond the map fits nothing: an error naming the map.
    for text in [
        "16,16,18446744073709551599,0",
        "16,16,0,18446744073709551599",
    ] {
        let e = grid(text).layout(64, 64).unwrap_err();
        assert!(e.to_string().contains("64x64 px map"), "{text}: {e}");
        assert_eq!(field(e), "subap_grid");
    }
    // The largest pitch: one sub-aperture per axis, at the origin.
    let l = grid("16,18446744073709551615,8,8").layout(64, 64).unwrap();
    assert_eq!(l.subaps.len(), 1);
    assert_eq!((l.subaps[0].x0_px, l.subaps[0].y0_px), (8, 8));
    // A grid built in code without parse is checked by layout too.
    let raw = Geometry {
        grid: GridSpec {
            size_px: 16,
            pitch_px: 16,
            x0_px: usize::MAX - 3,
            y0_px: 0,
        },
        mask: None,
    };
    assert_eq!(field(raw.layout(64, 64).unwrap_err()), "subap_grid");
}

#[test]
fn masks_select_cells_and_must_have_the_grids_shape() {
    // A 2x2 mask on a map that fits 2x2: the masked cell (0, 1) is skipped.
    let mask = |rows, cols, valid: Vec<bool>| Geometry {
        grid: GridSpec::parse("4").unwrap(),
        mask: Some(ValidMask::new(rows, cols, valid)),
    };
    let l = mask(2, 2, vec![true, false, true, true])
        .layout(8, 8)
        .unwrap();
    assert_eq!((l.grid_rows, l.grid_cols, l.masked), (2, 2, 1));
    let cells: Vec<(usize, usize)> = l.subaps.iter().map(|s| (s.grid_row, s.grid_col)).collect();
    assert_eq!(cells, [(0, 0), (1, 0), (1, 1)]);
    assert_eq!(l.subaps[2].index, 2);
    // A mask of another shape, smaller or larger, is refused naming both shapes (it neither
    // shrinks the grid nor leaves cells out).
    for (rows, cols) in [(1, 2), (3, 3), (2, 3)] {
        let e = mask(rows, cols, vec![true; rows * cols])
            .layout(8, 8)
            .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains(&format!("{rows}x{cols} cells")) && msg.contains("2x2 sub-apertures"),
            "{msg}"
        );
        assert_eq!(field(e), "subap_mask");
    }
    // A mask with no valid cell.
    let e = mask(2, 2, vec![false; 4]).layout(8, 8).unwrap_err();
    assert!(e.to_string().contains("none"), "{e}");
    assert_eq!(field(e), "subap_mask");
    // Read from a file: non-zero is valid; NaN is refused naming the file.
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("mask.fits");
    Map::new(1, 3, vec![0.0, 2.0, -1.0], Unit::Flags)
        .write_fits(&p, &[])
        .unwrap();
    assert_eq!(ValidMask::read(&p).unwrap().valid, [false, true, true]);
    Map::new(1, 2, vec![1.0, f64::NAN], Unit::Flags)
        .write_fits(&p, &[])
        .unwrap();
    assert!(ValidMask::read(&p)
        .unwrap_err()
        .to_string()
        .contains("mask.fits"));
    // Shards deal the sub-apertures round-robin.
    let l = grid("2").layout(4, 6).unwrap();
    let idx = |k| l.shard(k, 4).iter().map(|s| s.index).collect::<Vec<_>>();
    assert_eq!((idx(1), idx(2), idx(4)), (vec![0, 4], vec![1, 5], vec![3]));
}

/// A map of `rows` x `cols` blocks of `n` x `n` px, block (r, c) at the constant `sigma[r][c]`.
fn block_map(n: usize, sigma: &[&[f64]]) -> Map {
    let (rows, cols) = (sigma.len() * n, sigma[0].len() * n);
    let data = (0..rows * cols)
        .map(|i| sigma[i / cols / n][i % cols / n])
        .collect();
    Map::new(rows, cols, data, Unit::Electrons).with_source("blocks.fits")
}

fn config(n: usize, iters: u64) -> SimConfig {
    SimConfig {
        iters,
        ..SimConfig::paper(n)
    }
}

#[test]
fn each_window_is_its_own_constant_readout() {
    // Sub-apertures whose windows hold one sigma each (each a uniform camera): sigma_eff is
    // that sigma within 3 SE (the definition, inverted on the Monte-Carlo's own ladder), and
    // agrees with `effective` solving the same window on its own (its own references around
    // its estimate) within 3 combined SE.
    let sigmas: [&[f64]; 2] = [&[0.5, 1.0], &[2.0, 1.5]];
    let map = block_map(6, &sigmas);
    let geometry = grid("6");
    let job = SubapsJob {
        map: &map,
        geometry: &geometry,
        config: config(6, 4000),
        precision: Precision::fixed(4000),
        centroider: Default::default(),
    };
    let (header, records) = solve_all(&job, &Silent).unwrap();
    assert_eq!(header.binding.subaps, 4);
    let noise = NoiseMap::new(&map).unwrap();
    let layout = geometry.layout(map.rows, map.cols).unwrap();
    for r in &records {
        let s = sigmas[r.grid_row][r.grid_col];
        assert_eq!((r.status, r.iters), (Status::Ok, 4000));
        let se = r.sigma_eff_se_e;
        assert!(se > 0.0 && se < 0.1 * s, "{s}: SE {se}");
        assert!(
            (r.sigma_eff_e - s).abs() <= 3.0 * se,
            "{s}: {} ± {se}",
            r.sigma_eff_e
        );
        let window = noise.readout(&layout.subaps[r.index], 6);
        let direct = effective_sigma(&job.config, &window, &job.precision, &Silent).unwrap();
        let combined = se.hypot(direct.sigma_eff_se_e);
        assert!(
            (r.sigma_eff_e - direct.sigma_eff_e).abs() <= 3.0 * combined,
            "{s}: {} vs effective {} ± {combined}",
            r.sigma_eff_e,
            direct.sigma_eff_e
        );
        // R is the window's own, whoever runs it (common random numbers).
        assert_eq!(r.r_px.to_bits(), direct.r_px.to_bits());
        assert_eq!(
            r.window,
            WindowStats {
                median_e: s,
                rms_e: s,
                nonfinite_px: 0
            }
        );
    }
}

#[test]
fn a_model_reads_the_same_frames_beside_any_other_and_on_any_thread_count() {
    // The ladder rests on this: a readout's result does not depend on which other models
    // share its experiment, nor on the threads that run it.
    let cfg = config(6, 3000);
    let a = ScmosConstant::new(0.8, "a".into());
    let (b, c) = (
        ScmosConstant::new(2.0, "b".into()),
        ScmosConstant::new(0.1, "c".into()),
    );
    let run = |models: &[&dyn crate::detector::Readout], threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| crate::montecarlo::run(&cfg, models, &Silent).unwrap())
    };
    let alone = &run(&[&a], 1)[0];
    let beside = &run(&[&b, &a, &c], 3)[1];
    assert_eq!(alone.r_px.to_bits(), beside.r_px.to_bits());
    assert_eq!(alone.best, beside.best);
    let bits = |r: &crate::montecarlo::SimResult| -> Vec<u64> {
        r.levels.iter().map(|l| l.r_px.to_bits()).collect()
    };
    assert_eq!(bits(alone), bits(beside));
}

/// The record lines of `job` solved in memory on `threads` threads.
fn lines_on(job: &SubapsJob, threads: usize) -> Vec<String> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let (_, records) = pool.install(|| solve_all(job, &Silent)).unwrap();
    records.iter().map(|r| r.line()).collect()
}

#[test]
fn a_uniform_map_to_a_target_gives_its_sigma_whatever_the_threads() {
    // A uniform 1.2 e- camera solved to 0.001 e- from 1024 frames (a window that reads like a
    // constant is close to the ladder's references: its paired SE is small, a few 0.001 e-):
    // every sub-aperture is run again to a later checkpoint of the shared ladder and lands
    // within 3 SE of 1.2 e-; one thread and three give the same lines, whichever groups they
    // formed.
    let map = Map::new(12, 12, vec![1.2; 144], Unit::Electrons).with_source("uniform.fits");
    let geometry = grid("4");
    let target = Precision {
        target_se_e: 0.001,
        target_rel: 0.0,
        max_iters: 40_000,
    };
    let job = SubapsJob {
        map: &map,
        geometry: &geometry,
        config: config(4, 1024),
        precision: target,
        centroider: Default::default(),
    };
    let lines = lines_on(&job, 1);
    assert_eq!(lines, lines_on(&job, 3));
    let (_, records) = solve_all(&job, &Silent).unwrap();
    assert_eq!(records.len(), 9);
    for r in &records {
        assert_eq!(r.status, Status::Ok);
        assert!(r.iters > 1024 && r.sigma_eff_se_e <= 0.001, "{r:?}");
        assert!(
            (r.sigma_eff_e - 1.2).abs() <= 3.0 * r.sigma_eff_se_e,
            "{r:?}"
        );
    }
    // A varied map to a target: sub-apertures settle at different checkpoints (groups run
    // on past some members' and send others to later rounds); the lines do not depend on the
    // threads either.
    let map = small_map();
    let job = SubapsJob {
        map: &map,
        geometry: &geometry,
        config: config(4, 1000),
        precision: Precision {
            target_se_e: 0.02,
            ..target
        },
        centroider: Default::default(),
    };
    let lines = lines_on(&job, 1);
    assert_eq!(lines, lines_on(&job, 2));
    let iters: std::collections::BTreeSet<&str> = lines
        .iter()
        .map(|l| l.split('\t').nth(7).unwrap())
        .collect();
    assert!(iters.len() >= 3, "{iters:?}");
    // Each varied window's value agrees with `effective` solving that window alone.
    let (_, records) = solve_all(&job, &Silent).unwrap();
    let noise = NoiseMap::new(&map).unwrap();
    let layout = geometry.layout(map.rows, map.cols).unwrap();
    for r in records.iter().filter(|r| r.status == Status::Ok) {
        let window = noise.readout(&layout.subaps[r.index], 4);
        let direct = effective_sigma(&job.config, &window, &job.precision, &Silent).unwrap();
        let combined = r.sigma_eff_se_e.hypot(direct.sigma_eff_se_e);
        assert!(
            (r.sigma_eff_e - direct.sigma_eff_e).abs() <= 3.0 * combined,
            "{r:?} vs {direct:?}"
        );
    }
}

#[test]
fn other_centroiders_are_matched_against_references_read_the_same_way() {
    // A uniform window read through wcog: its sigma_eff (references through wcog, each at
    // its own best parameter) is its sigma within 3 SE; the cog-equivalent (references through
    // cog) is another number, with its own SE.
    let map = Map::new(6, 6, vec![1.0; 36], Unit::Electrons).with_source("uniform.fits");
    let noise = NoiseMap::new(&map).unwrap();
    let subaps = grid("6").layout(6, 6).unwrap().subaps;
    let cfg = config(6, 4000);
    let precision = Precision::fixed(4000);
    let centroider = crate::centroid::CentroiderSpec::parse("wcog").unwrap();
    let sigmas = ladder::ladder_sigmas(&noise);
    let references = ladder::references(&sigmas);
    let checkpoints = ladder::checkpoints(cfg.iters, &precision);
    let mut ladder =
        ladder::Ladder::new(&cfg, (sigmas, &references), centroider, checkpoints).unwrap();
    ladder.reach(0, &Silent, 0).unwrap();
    let steps = solve::solve_group(
        (&cfg, &noise, centroider),
        &ladder,
        &[(0, subaps[0])],
        &precision,
        &Silent,
    )
    .unwrap();
    let solve::Step::Done(e) = &steps[0] else {
        panic!("a fixed count settles at once")
    };
    assert_eq!(e.status, Status::Ok);
    assert!(
        (e.sigma_eff_e - 1.0).abs() <= 3.0 * e.sigma_eff_se_e,
        "{e:?}"
    );
    assert!(e.sigma_cog_equiv_se_e > 0.0 && e.sigma_cog_equiv_se_e.is_finite());
    assert!((e.sigma_cog_equiv_e - e.sigma_eff_e).abs() > 3.0 * e.sigma_cog_equiv_se_e);
}

#[test]
fn non_finite_pixels_read_with_the_map_rms_like_scmos_map() {
    // rms of the finite pixels: sqrt((3 x 4 + 16) / 4)... of a 2x2 map [2, NaN, 2, 4]:
    // sqrt((4 + 4 + 16) / 3) = sqrt(8), as scmos-map reads them.
    let map = Map::new(2, 2, vec![2.0, f64::NAN, 2.0, 4.0], Unit::Electrons);
    let noise = NoiseMap::new(&map).unwrap();
    assert_eq!(noise.fill_e, 8f64.sqrt());
    let s = grid("2").layout(2, 2).unwrap().subaps[0];
    assert_eq!(noise.readout(&s, 2).sigma_e(), [2.0, 8f64.sqrt(), 2.0, 4.0]);
    let w = WindowStats::of(&noise.window(&s, 2));
    assert_eq!((w.median_e, w.nonfinite_px), (2.0, 1));
    assert_eq!(w.rms_e, 8f64.sqrt());
    // A map in adu, or without a finite pixel, is refused naming its source.
    let adu = Map::new(2, 2, vec![1.0; 4], Unit::Adu).with_source("rms_adu.fits");
    assert!(NoiseMap::new(&adu)
        .unwrap_err()
        .to_string()
        .contains("rms_adu.fits"));
    let none = Map::new(1, 2, vec![f64::NAN; 2], Unit::Electrons).with_source("nan.fits");
    assert!(NoiseMap::new(&none).is_err());
}

#[test]
fn record_lines_round_trip_exactly_and_torn_lines_are_recognised() {
    let r = PartRecord {
        index: 17,
        grid_row: 2,
        grid_col: 3,
        status: Status::Unreachable,
        sigma_eff_e: f64::NAN,
        sigma_eff_se_e: f64::INFINITY,
        target_se_e: None,
        iters: 80_000,
        r_px: 0.1 + 0.2,
        r_se_px: 1e-300,
        b_opt_e: 1.0 / 3.0,
        window: WindowStats {
            median_e: 0.7,
            rms_e: f64::NAN,
            nonfinite_px: 3,
        },
        sigma_cog_equiv_e: 2.0 / 3.0,
        sigma_cog_equiv_se_e: f64::NAN,
        parts: EffectiveParts {
            static_x_px: -0.1,
            static_resolved: true,
            sigma_random_extrapolated: true,
            ..Default::default()
        },
    };
    let line = r.line();
    assert!(line.ends_with('\n') && line.matches('\n').count() == 1);
    let back = PartRecord::parse(line.trim_end()).unwrap();
    assert_eq!(back.r_px.to_bits(), r.r_px.to_bits());
    assert_eq!(back.b_opt_e.to_bits(), r.b_opt_e.to_bits());
    assert!(back.sigma_eff_e.is_nan() && back.sigma_eff_se_e == f64::INFINITY);
    assert_eq!(
        back.sigma_cog_equiv_e.to_bits(),
        r.sigma_cog_equiv_e.to_bits()
    );
    assert_eq!(back.parts.static_x_px, -0.1);
    assert!(back.parts.static_resolved && back.parts.sigma_random_extrapolated);
    assert!(back.parts.sigma_random_e.is_nan() && back.sigma_cog_equiv_se_e.is_nan());
    assert_eq!(
        (back.index, back.status, back.target_se_e),
        (17, Status::Unreachable, None)
    );
    let ok = PartRecord {
        target_se_e: Some(0.05),
        status: Status::Ok,
        sigma_eff_e: 1.25,
        ..r
    };
    assert_eq!(
        PartRecord::parse(ok.line().trim_end()).unwrap().target_se_e,
        Some(0.05)
    );
    // Cut short, or one character changed: not a record.
    assert!(PartRecord::parse(&line[..line.len() / 2]).is_none());
    assert!(PartRecord::parse(&line.trim_end().replacen("80000", "80001", 1)).is_none());
}

#[test]
fn shards_parse_and_name_their_part() {
    assert_eq!(Shard::parse("3/8").unwrap(), Shard { k: 3, n: 8 });
    assert_eq!(Shard::parse(" 1 / 1 ").unwrap(), Shard::ALL);
    assert_eq!(
        Shard::parse("2/3").unwrap().file_name(),
        "subaps-2-of-3.part"
    );
    for bad in ["", "3", "0/3", "4/3", "a/b", "1/0", "-1/3", "1/3/4"] {
        let e = Shard::parse(bad).unwrap_err();
        assert_eq!(field(e), "shard", "{bad:?}");
    }
    assert!(is_part_name(Path::new("d/subaps-2-of-3.part")));
    assert!(!is_part_name(Path::new("subaps-x-of-3.part")));
}

/// The job of the resume and shard tests: a 12x16 px map of 4x4 px sub-apertures with
/// varied per-pixel noise (3x4 = 12 sub-apertures), few iterations.
fn small_map() -> Map {
    let data = (0..12 * 16)
        .map(|i| 0.6 + ((i * 37) % 23) as f64 * 0.15)
        .collect();
    Map::new(12, 16, data, Unit::Electrons).with_source("small.fits")
}

fn small_job<'a>(map: &'a Map, geometry: &'a Geometry, seed: u64) -> SubapsJob<'a> {
    SubapsJob {
        map,
        geometry,
        config: SimConfig {
            seed,
            ..config(4, 1000)
        },
        precision: Precision::fixed(1000),
        centroider: Default::default(),
    }
}

fn run(
    job: &SubapsJob,
    shard: Shard,
    out: &Path,
    observer: &dyn crate::progress::Observer,
) -> crate::Result<DirRun> {
    let target = DirTarget {
        out,
        force: false,
        inputs: &[],
    };
    run_into_dir(job, shard, &target, observer)
}

fn read(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn three_shards_merged_equal_one_run_byte_for_byte() {
    let (map, geometry) = (small_map(), grid("4"));
    let job = small_job(&map, &geometry, 1);
    let d = tempfile::tempdir().unwrap();
    let (single, parts, merged) = (
        d.path().join("one"),
        d.path().join("parts"),
        d.path().join("merged"),
    );
    let one = run(&job, Shard::ALL, &single, &Silent).unwrap();
    assert_eq!((one.in_shard, one.computed, one.resumed), (12, 12, 0));
    for k in 1..=3 {
        let r = run(&job, Shard { k, n: 3 }, &parts, &Silent).unwrap();
        assert_eq!((r.in_shard, r.summary.is_none()), (4, true));
    }
    // A shard writes only its part file.
    let mut names: Vec<String> = std::fs::read_dir(&parts)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "subaps-1-of-3.part",
            "subaps-2-of-3.part",
            "subaps-3-of-3.part"
        ]
    );
    let (m, summary) = merge_into_dir(std::slice::from_ref(&parts), &merged, false).unwrap();
    assert_eq!((m.records.len(), m.parts.len()), (12, 3));
    let counted: usize = Status::ALL.iter().map(|s| summary.count(*s)).sum();
    assert_eq!(counted, 12);
    for name in OUTPUT_NAMES {
        assert_eq!(read(&single, name), read(&merged, name), "{name} differs");
    }
    // The records are the same job's: what each sub-aperture gives alone.
    let alone = solve_all(&job, &Silent).unwrap().1;
    assert_eq!(alone, m.records);
}

#[test]
fn merge_refuses_incomplete_duplicated_and_foreign_parts() {
    let (map, geometry) = (small_map(), grid("4"));
    let d = tempfile::tempdir().unwrap();
    let (a, b) = (d.path().join("a"), d.path().join("b"));
    for k in 1..=3 {
        run(
            &small_job(&map, &geometry, 1),
            Shard { k, n: 3 },
            &a,
            &Silent,
        )
        .unwrap();
    }
    run(
        &small_job(&map, &geometry, 2),
        Shard { k: 3, n: 3 },
        &b,
        &Silent,
    )
    .unwrap();
    let part = |dir: &Path, k: usize| dir.join(format!("subaps-{k}-of-3.part"));
    let out = d.path().join("out");
    // Missing shard 3: the count and the way out.
    let e = merge_into_dir(&[part(&a, 1), part(&a, 2)], &out, false).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("4 of 12 sub-apertures are missing"), "{msg}");
    assert_eq!(field(e), "parts");
    // A part given twice.
    let e = merge_into_dir(
        &[part(&a, 1), part(&a, 2), part(&a, 3), part(&a, 1)],
        &out,
        false,
    );
    assert!(e.unwrap_err().to_string().contains("holds too"));
    // Shard 3 of another seed: another job, naming the setting.
    let e = merge_into_dir(&[part(&a, 1), part(&a, 2), part(&b, 3)], &out, false).unwrap_err();
    assert!(
        e.to_string().contains("another job") && e.to_string().contains("seed"),
        "{e}"
    );
    // An incomplete part (its last record cut) is named.
    let cut = d.path().join("cut");
    std::fs::create_dir(&cut).unwrap();
    let text = std::fs::read_to_string(part(&a, 3)).unwrap();
    let keep = text.len() - text.lines().last().unwrap().len() / 2 - 1;
    std::fs::write(part(&cut, 3), &text[..keep]).unwrap();
    let e = merge_into_dir(&[part(&a, 1), part(&a, 2), part(&cut, 3)], &out, false).unwrap_err();
    assert!(
        e.to_string().contains("3 of 4 done, a torn last line"),
        "{e}"
    );
    // A damaged line with more after it: the part is refused as altered.
    let lines: Vec<&str> = text.lines().collect();
    let damaged = format!("{}\n{}x\n{}\n", lines[0], lines[1], lines[2..].join("\n"));
    std::fs::write(part(&cut, 3), damaged).unwrap();
    let e = merge_into_dir(&[part(&cut, 3)], &out, false).unwrap_err();
    assert!(e.to_string().contains("line 2 is damaged"), "{e}");
    assert!(!out.exists(), "no output after a refused merge");
}

#[test]
fn a_killed_run_resumes_without_recomputing_finished_sub_apertures() {
    let (map, geometry) = (small_map(), grid("4"));
    let job = small_job(&map, &geometry, 1);
    let d = tempfile::tempdir().unwrap();
    let (full, killed) = (d.path().join("full"), d.path().join("killed"));
    run(&job, Shard::ALL, &full, &Silent).unwrap();
    let name = Shard::ALL.file_name();
    let content = read_part(&full.join(&name)).unwrap();
    // The state of a run killed after two sub-apertures, while writing the third: the
    // header, two records (the second altered: a recomputation would restore it) and half a
    // line.
    let mut altered = content.records[1].clone();
    altered.r_px = 0.123;
    let third = content.records[2].line();
    let header = std::fs::read_to_string(full.join(&name)).unwrap();
    let header = header.lines().next().unwrap();
    std::fs::create_dir(&killed).unwrap();
    let text = format!(
        "{header}\n{}{}{}",
        content.records[0].line(),
        altered.line(),
        &third[..third.len() / 2]
    );
    std::fs::write(killed.join(&name), text).unwrap();
    let rec = Recorder::default();
    let r = run(&job, Shard::ALL, &killed, &rec).unwrap();
    assert_eq!((r.resumed, r.computed), (2, 10));
    assert_eq!(rec.stages.lock().unwrap()[0].1, 10);
    assert_eq!(rec.advanced.load(Relaxed), 10);
    let resumed = read_part(&killed.join(&name)).unwrap();
    assert!(!resumed.torn);
    let mut expect = content.records.clone();
    let mut got = resumed.records.clone();
    expect.sort_by_key(|r| r.index);
    got.sort_by_key(|r| r.index);
    let i = altered.index;
    expect[i] = altered;
    assert_eq!(got, expect);
    // A rerun of the finished job computes nothing and writes the same files.
    let csv = read(&full, "subaps.csv");
    let again = run(&job, Shard::ALL, &full, &Silent).unwrap();
    assert_eq!((again.resumed, again.computed), (12, 0));
    assert_eq!(csv, read(&full, "subaps.csv"));
    // Other options in the same directory are refused before any work, naming them.
    let other = small_job(&map, &geometry, 7);
    let e = run(&other, Shard::ALL, &full, &Silent).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("seed") && msg.contains(&name), "{msg}");
    assert_eq!(field(e), "out");
}

#[test]
fn an_output_directory_with_foreign_files_is_refused_without_force() {
    let (map, geometry) = (small_map(), grid("4"));
    let job = small_job(&map, &geometry, 1);
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("mine");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "keep me").unwrap();
    let e = run(&job, Shard { k: 1, n: 2 }, &out, &Silent).unwrap_err();
    assert_eq!(field(e), "out");
    assert!(!out.join("subaps-1-of-2.part").exists());
    let target = DirTarget {
        out: &out,
        force: true,
        inputs: &[PathBuf::from("x")],
    };
    run_into_dir(&job, Shard::ALL, &target, &Silent).unwrap();
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "keep me"
    );
    assert!(out.join("subaps_sigma_eff_e.fits").exists());
}

#[test]
fn the_images_hold_ok_values_only_and_the_status_codes() {
    let (map, geometry) = (small_map(), grid("4"));
    let job = small_job(&map, &geometry, 1);
    let (header, mut records) = solve_all(&job, &Silent).unwrap();
    records[0].status = Status::Imprecise;
    let d = tempfile::tempdir().unwrap();
    let (summary, files) = write_outputs(&header, &records, d.path()).unwrap();
    assert_eq!(files.len(), OUTPUT_NAMES.len());
    let imprecise = records
        .iter()
        .filter(|r| r.status == Status::Imprecise)
        .count();
    assert_eq!(summary.count(Status::Imprecise), imprecise);
    let sigma = Map::read(d.path().join("subaps_sigma_eff_e.fits"), Unit::Electrons).unwrap();
    let status = Map::read(d.path().join("subaps_status.fits"), Unit::Flags).unwrap();
    assert_eq!(sigma.shape(), (3, 4));
    assert!(sigma.data[0].is_nan());
    assert_eq!(status.data[0], status_code(Status::Imprecise) as f64);
    for r in &records[1..] {
        let cell = r.grid_row * 4 + r.grid_col;
        assert_eq!(status.data[cell], status_code(r.status) as f64);
        if r.status == Status::Ok {
            assert_eq!(sigma.data[cell], r.sigma_eff_e);
        } else {
            assert!(sigma.data[cell].is_nan());
        }
    }
    let csv = std::fs::read_to_string(d.path().join("subaps.csv")).unwrap();
    assert!(!csv.to_lowercase().contains("nan") && !csv.contains("inf"));
    assert!(csv.starts_with("index,grid_row,grid_col,x0_px,y0_px,sigma_eff_e,sigma_eff_se_e"));
    assert_eq!(csv.lines().count(), 13);
}

#[test]
fn a_large_grid_is_drawn_as_an_image_with_its_files_complete() {
    // 30x30 sub-apertures (above the heatmap's side): records made up, every tenth unreachable.
    let map = Map::filled(60, 60, 1.0, Unit::Electrons).with_source("flat.fits");
    let geometry = grid("2");
    let job = small_job(&map, &geometry, 1);
    let plan = SubapsJob {
        config: config(2, 1000),
        ..job
    }
    .plan()
    .unwrap();
    let window = WindowStats::of(&[1.0; 4]);
    let records: Vec<PartRecord> = plan
        .layout
        .subaps
        .iter()
        .map(|s| PartRecord {
            index: s.index,
            grid_row: s.grid_row,
            grid_col: s.grid_col,
            status: if s.index % 10 == 0 {
                Status::Unreachable
            } else {
                Status::Ok
            },
            sigma_eff_e: if s.index % 10 == 0 {
                f64::NAN
            } else {
                1.0 + s.index as f64 / 900.0
            },
            sigma_eff_se_e: 0.01,
            target_se_e: Some(0.05),
            iters: 1000,
            r_px: 0.3,
            r_se_px: 0.001,
            b_opt_e: 1.0,
            window,
            sigma_cog_equiv_e: 1.0,
            sigma_cog_equiv_se_e: 0.01,
            parts: EffectiveParts {
                static_x_px: 0.01 * s.grid_col as f64,
                static_y_px: -0.01 * s.grid_row as f64,
                ..Default::default()
            },
        })
        .collect();
    let d = tempfile::tempdir().unwrap();
    let (summary, _) = write_outputs(&plan.header(Shard::ALL), &records, d.path()).unwrap();
    assert_eq!(
        (
            summary.count(Status::Ok),
            summary.count(Status::Unreachable)
        ),
        (810, 90)
    );
    let spread = summary.sigma_eff_ok.unwrap();
    assert_eq!((spread.ok, spread.min_e), (810, 1.0 + 1.0 / 900.0));
    for name in ["subaps_sigma_eff.png", "subaps_sigma_eff.svg"] {
        assert!(
            std::fs::metadata(d.path().join(name)).unwrap().len() > 1000,
            "{name}"
        );
    }
    let sigma = Map::read(d.path().join("subaps_sigma_eff_e.fits"), Unit::Electrons).unwrap();
    assert_eq!(sigma.shape(), (30, 30));
    assert!(sigma.data[0].is_nan() && sigma.data[1] == 1.0 + 1.0 / 900.0);
    // The static offset as a vector map, every sub-aperture's (whatever its status).
    let sx = crate::io::read_image(&d.path().join("static_x_px.fits")).unwrap();
    assert_eq!(sx.bunit.as_deref(), Some("pixel"));
    assert_eq!((sx.data[0], sx.data[31]), (0.0, 0.01));
    let csv = std::fs::read_to_string(d.path().join("subaps.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(
        "sigma_cog_equiv_e,sigma_cog_equiv_se_e,static_x_px,static_y_px,static_px,static_se_px,\
         static_resolved,random_rms_px,sigma_random_e,sigma_random_se_e"
    ));
}

#[test]
fn a_centroider_that_cannot_read_the_windows_is_refused_before_any_output() {
    let (map, geometry) = (small_map(), grid("4"));
    let job = SubapsJob {
        centroider: crate::centroid::CentroiderSpec::parse("brightest-n:1000").unwrap(),
        ..small_job(&map, &geometry, 1)
    };
    let msg = job.plan().err().unwrap().to_string();
    assert!(
        msg.contains("brightest-n:1000") && msg.contains("16 pixels"),
        "{msg}"
    );
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let e = run(&job, Shard::ALL, &out, &Silent).unwrap_err();
    assert_eq!(field(e), "centroider");
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
}

/// A part file of the small job's whole run in `dir`: its path and its text.
fn whole_part(dir: &Path) -> (PathBuf, String) {
    let (map, geometry) = (small_map(), grid("4"));
    run(&small_job(&map, &geometry, 1), Shard::ALL, dir, &Silent).unwrap();
    let p = dir.join(Shard::ALL.file_name());
    let text = std::fs::read_to_string(&p).unwrap();
    (p, text)
}

#[test]
fn a_part_whose_header_was_edited_is_refused_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let (p, text) = whole_part(&d.path().join("a"));
    let out = d.path().join("merged");
    let edits = [
        (
            "\"signal_photons\":50.0",
            "\"signal_photons\":500.0",
            "binding_blake3",
        ),
        (
            "\"shard\":{\"k\":1,\"n\":1}",
            "\"shard\":{\"k\":0,\"n\":0}",
            "shard 0/0",
        ),
        (
            "\"subaps_in_shard\":12",
            "\"subaps_in_shard\":13",
            "counts 13",
        ),
    ];
    for (from, to, why) in edits {
        assert!(text.contains(from), "{from} not in {text}");
        std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
        let msg = read_part(&p).unwrap_err().to_string();
        assert!(
            msg.contains(why) && msg.contains("subaps-1-of-1.part"),
            "{msg}"
        );
        let msg = merge_into_dir(std::slice::from_ref(&p), &out, false)
            .unwrap_err()
            .to_string();
        assert!(msg.contains(why), "{msg}");
        assert!(!out.exists());
    }
}

#[test]
fn a_damaged_part_in_the_output_directory_is_refused_for_what_it_is() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("a");
    let (p, text) = whole_part(&dir);
    // One flipped byte in the first record: the reason, without --force.
    let mut bytes = text.into_bytes();
    let at = bytes.iter().position(|&b| b == b'\n').unwrap() + 3;
    bytes[at] ^= 0x01;
    std::fs::write(&p, &bytes).unwrap();
    let (map, geometry) = (small_map(), grid("4"));
    let e = run(&small_job(&map, &geometry, 1), Shard::ALL, &dir, &Silent).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("line 2 is damaged") && msg.contains("subaps-1-of-1.part"),
        "{msg}"
    );
    assert_eq!(std::fs::read(&p).unwrap(), bytes, "the part is untouched");
}

#[test]
fn a_part_is_written_by_one_run_at_a_time() {
    let d = tempfile::tempdir().unwrap();
    let (map, geometry) = (small_map(), grid("4"));
    let plan = small_job(&map, &geometry, 1).plan().unwrap();
    let header = plan.header(Shard { k: 1, n: 2 });
    let (first, _) = part::PartWriter::open(d.path(), &header).unwrap();
    let lock = d.path().join("subaps-1-of-2.part.lock");
    assert_eq!(
        std::fs::read_to_string(&lock).unwrap(),
        format!("{}\n", std::process::id())
    );
    let before = std::fs::read(first.path()).unwrap();
    let e = part::PartWriter::open(d.path(), &header).err().unwrap();
    let msg = e.to_string();
    assert!(
        msg.contains(&format!("pid {}", std::process::id())) && msg.contains("subaps-1-of-2.part"),
        "{msg}"
    );
    assert_eq!(field(e), "out");
    assert_eq!(std::fs::read(first.path()).unwrap(), before);
    // Another shard is another lock.
    part::PartWriter::open(d.path(), &plan.header(Shard { k: 2, n: 2 })).unwrap();
    // Released (and its file removed) when the writer ends; a lock file left by a killed run,
    // whose process holds no lock, does not block.
    drop(first);
    assert!(!lock.exists());
    std::fs::write(&lock, "999999\n").unwrap();
    let (again, done) = part::PartWriter::open(d.path(), &header).unwrap();
    assert!(done.is_empty());
    drop(again);
    assert!(!lock.exists());
}

#[test]
fn the_summary_names_the_map_read_by_this_run() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let geometry = grid("4");
    let summary = |map: &Map| {
        let r = run(&small_job(map, &geometry, 1), Shard::ALL, &out, &Silent).unwrap();
        r.summary.unwrap().map_source
    };
    assert_eq!(summary(&small_map()), "small.fits");
    // The same values under another name (the map renamed): resumed, and named as read now.
    let renamed = small_map().with_source("renamed.fits");
    assert_eq!(summary(&renamed), "renamed.fits");
    let json = std::fs::read_to_string(out.join("subaps_summary.json")).unwrap();
    assert!(
        json.contains("renamed.fits") && !json.contains("small.fits"),
        "{json}"
    );
}

#[test]
fn a_part_whose_floats_do_not_round_trip_through_json_parsing_still_resumes() {
    // serde_json reads 0.9941414234139935 as 0.9941414234139936: the checksum is of the
    // binding as written, not of the parsed one re-encoded.
    let (map, geometry) = (small_map(), grid("4"));
    let mut job = small_job(&map, &geometry, 1);
    job.config.qe = 0.9941414234139935;
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    run(&job, Shard::ALL, &out, &Silent).unwrap();
    let again = run(&job, Shard::ALL, &out, &Silent).unwrap();
    assert_eq!((again.resumed, again.computed), (12, 0));
    let part = out.join(Shard::ALL.file_name());
    merge_into_dir(&[part], &d.path().join("merged"), false).unwrap();
}
