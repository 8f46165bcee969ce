use super::*;
use crate::calib::{Map, Unit};
use crate::detector::ScmosConstant;
use crate::effective::{effective_sigma, Precision, Status};
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
    assert_eq!((l.subaps.len(), l.left_out), (4, 0));
    // Nothing fits: an error of the grid naming the map's size.
    let e = grid("16,16,50,0").layout(64, 64).unwrap_err();
    assert!(e.to_string().contains("64x64 px map"), "{e}");
    assert_eq!(field(e), "subap_grid");
    assert_eq!(field(grid("32").layout(16, 64).unwrap_err()), "subap_grid");
}

#[test]
fn masks_select_cells_and_cells_beyond_the_map_are_left_out() {
    // A 3x3 mask on a map that fits 2x2: the third row and column are left out (5 cells, of
    // which one is masked), the masked cell (0, 1) is skipped.
    let valid = vec![true, false, true, true, true, true, true, false, true];
    let geo = Geometry {
        grid: GridSpec::parse("4").unwrap(),
        mask: Some(ValidMask::new(3, 3, valid)),
    };
    let l = geo.layout(8, 8).unwrap();
    assert_eq!((l.grid_rows, l.grid_cols), (3, 3));
    let cells: Vec<(usize, usize)> = l.subaps.iter().map(|s| (s.grid_row, s.grid_col)).collect();
    assert_eq!(cells, [(0, 0), (1, 0), (1, 1)]);
    assert_eq!((l.masked, l.left_out), (2, 4));
    assert_eq!(l.subaps[2].index, 2);
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
    // Sub-apertures whose windows hold one sigma each: a constant window reads exactly like
    // scmos-constant at that sigma (same formula, same random numbers), so its solve is the
    // constant's bit for bit, and sigma_eff is the sigma within 4 SE (the definition of
    // sigma_eff, inverted on the Monte-Carlo's own R curve).
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
    for r in &records {
        let s = sigmas[r.grid_row][r.grid_col];
        let constant = ScmosConstant::new(s, "c".into());
        let direct = effective_sigma(&job.config, &constant, &job.precision, &Silent).unwrap();
        assert_eq!(r.status, direct.status);
        assert_eq!(r.sigma_eff_e.to_bits(), direct.sigma_eff_e.to_bits(), "{s}");
        assert_eq!(r.sigma_eff_se_e.to_bits(), direct.sigma_eff_se_e.to_bits());
        assert_eq!(r.r_px.to_bits(), direct.r_px.to_bits());
        assert_eq!(r.status, Status::Ok);
        let se = r.sigma_eff_se_e;
        assert!(
            (r.sigma_eff_e - s).abs() <= 4.0 * se,
            "{s}: {} ± {se}",
            r.sigma_eff_e
        );
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
    };
    let line = r.line();
    assert!(line.ends_with('\n') && line.matches('\n').count() == 1);
    let back = PartRecord::parse(line.trim_end()).unwrap();
    assert_eq!(back.r_px.to_bits(), r.r_px.to_bits());
    assert_eq!(back.b_opt_e.to_bits(), r.b_opt_e.to_bits());
    assert!(back.sigma_eff_e.is_nan() && back.sigma_eff_se_e == f64::INFINITY);
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
}
