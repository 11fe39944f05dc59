//! Tests of [`super`]: the line walk, the column scans, the energy grid and the bundle search.

use super::*;
use glam::IVec3;

#[test]
fn dda_visits_the_cells_of_a_diagonal_and_an_axis_line() {
    let v = Volume::new(Vec3::ZERO, 1.0, 4);
    let mut cells = Vec::new();
    v.dda(Vec3::new(-0.9, -0.9, -0.9), Vec3::ONE.normalize(), |c| {
        cells.push(c)
    });
    // Through the main diagonal: (0,0,0), (1,1,1), (2,2,2), (3,3,3) and the cells where it
    // touches edges; all visited cells are distinct and include the four diagonal cells.
    for k in 0..4 {
        assert!(cells.contains(&(k * 16 + k * 4 + k)), "{cells:?}");
    }
    let mut sorted = cells.clone();
    sorted.dedup();
    assert_eq!(sorted.len(), cells.len());
    // A line along +x at y = z = 0.1 (cell 2 in y and z): 4 cells, in order.
    let mut cells = Vec::new();
    v.dda(Vec3::new(5.0, 0.1, 0.1), Vec3::NEG_X, |c| cells.push(c));
    assert_eq!(cells, vec![43, 42, 41, 40]);
    // A line missing the cube visits nothing.
    let mut n = 0;
    v.dda(Vec3::new(0.0, 2.0, 0.0), Vec3::X, |_| n += 1);
    assert_eq!(n, 0);
}

#[test]
fn dda_visits_exactly_the_cells_a_line_passes_through() {
    // Random lines through and past a 16³ grid: the cells visited are distinct, each next
    // to the one before (sharing a face), each met by the line, and every cell that a dense
    // sampling of the line finds (away from cell boundaries) is among them.
    let v = Volume::new(Vec3::new(0.3, -0.2, 0.1), 2.0, 16);
    let mut rng = crate::sampling::Pcg::new(7, 1);
    let mut lines = 0;
    for _ in 0..2000 {
        let o = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 6.0 - 3.0;
        let d = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0).normalize();
        let mut cells = Vec::new();
        v.dda(o, d, |c| cells.push(c));
        let Some((t0, t1)) = Volume::clip(o, d, v.lo, v.hi()) else {
            assert!(cells.is_empty());
            continue;
        };
        lines += 1;
        let coords = |c: usize| [c % 16, (c / 16) % 16, c / 256].map(|x| x as i64);
        let mut sorted = cells.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), cells.len(), "a cell visited twice");
        for w in cells.windows(2) {
            let (a, b) = (coords(w[0]), coords(w[1]));
            let steps: i64 = (0..3).map(|k| (a[k] - b[k]).abs()).sum();
            assert_eq!(
                steps, 1,
                "cells {} and {} are not face neighbours",
                w[0], w[1]
            );
        }
        for &c in &cells {
            let (lo, hi) = v.cell_bounds(c);
            let pad = Vec3::splat(1e-4);
            assert!(
                Volume::line_hits_box(o, d, lo - pad, hi + pad),
                "cell {c} off the line"
            );
        }
        for k in 0..=1000 {
            let p = o + d * (t0 + (t1 - t0) * k as f32 / 1000.0);
            let rel = (p - v.lo) / v.cell;
            let frac = rel - rel.floor();
            if frac.min_element() < 1e-3 || frac.max_element() > 1.0 - 1e-3 {
                continue;
            }
            let c = rel.floor().as_ivec3().clamp(IVec3::ZERO, IVec3::splat(15));
            let idx = (c.z * 256 + c.y * 16 + c.x) as usize;
            assert!(cells.contains(&idx), "cell {idx} on the line not visited");
        }
    }
    assert!(lines > 500, "{lines}");
}

#[test]
fn line_distance_test_agrees_with_the_distance() {
    let mut rng = crate::sampling::Pcg::new(5, 3);
    let unit = |rng: &mut crate::sampling::Pcg| {
        (Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0).normalize()
    };
    for k in 0..5000 {
        let q = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
        let b = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
        let a = unit(&mut rng);
        // Every tenth line is parallel to the axis.
        let d = if k % 10 == 0 { a } else { unit(&mut rng) };
        let dist = line_distance(q, d, b, a);
        for t in [0.2f32, 0.5, 1.0] {
            if (dist - t).abs() > 1e-4 {
                assert_eq!(within(q, d, b, a, t * t, -2.0), dist <= t, "{dist} {t}");
            }
        }
    }
}

/// Random caustic rays around the origin, every tenth along a coordinate axis.
fn random_rays(count: usize, seed: u64) -> Vec<CausticRay> {
    let mut rng = crate::sampling::Pcg::new(seed, 11);
    (0..count)
        .map(|k| {
            let mut v = || Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
            let origin = v() * 2.0;
            let dir = if k % 10 == 0 {
                [Vec3::X, Vec3::NEG_Y, Vec3::Z][k / 10 % 3]
            } else {
                v().normalize()
            };
            CausticRay {
                origin,
                dir,
                energy: v().abs(),
            }
        })
        .collect()
}

#[test]
fn column_scans_pass_the_rays_the_single_ray_tests_pass() {
    let rays = random_rays(20_000, 3);
    let idx: Vec<u32> = (0..rays.len() as u32).step_by(3).collect();
    let cols = Columns::of(&rays, &idx);
    let (b, a) = (
        Vec3::new(0.1, 0.2, -0.1),
        Vec3::new(0.3, 0.9, -0.2).normalize(),
    );
    for (dist, cos) in [(0.3f32, 0.5f32), (1.0, -1.0), (0.05, 0.9)] {
        let want: Vec<u32> = (0..idx.len() as u32)
            .filter(|&p| {
                let r = &rays[idx[p as usize] as usize];
                within(r.origin, r.dir, b, a, dist * dist, cos)
            })
            .collect();
        assert!(!want.is_empty());
        assert_eq!(cols.scan(b, a, dist, cos), want);
    }
    let (lo, hi) = (Vec3::new(-0.2, -0.1, 0.0), Vec3::new(0.1, 0.3, 0.25));
    let want: Vec<u32> = (0..idx.len() as u32)
        .filter(|&p| {
            let r = &rays[idx[p as usize] as usize];
            Volume::line_hits_box(r.origin, r.dir, lo, hi)
        })
        .collect();
    assert!(!want.is_empty());
    assert_eq!(cols.meeting_box(lo, hi), want);
    // Selecting and retaining keep indices and columns together.
    let mut sub = cols.select(&want);
    sub.retain(|i| i % 2 == 0);
    for (p, &i) in sub.idx.iter().enumerate() {
        assert_eq!(i % 2, 0);
        assert_eq!(sub.o[1][p], rays[i as usize].origin.y);
        assert_eq!(sub.d[2][p], rays[i as usize].dir.z);
    }
}

#[test]
fn rasterised_grid_is_the_energy_of_the_cells_each_line_visits() {
    // The grid (parallel shares, vector walk, dummy cells) against the cells the plain
    // walk visits, added one line at a time; and removing rays subtracts them exactly.
    let rays = random_rays(3000, 4);
    let volume = Volume::new(Vec3::new(0.1, 0.0, -0.1), 1.5, 24);
    // With a search sample (stride 4) only its lines are in the grid.
    let mut ex = Extractor::new(&rays, volume, 4);
    let grid_of = |keep: &dyn Fn(u32) -> bool, ex: &Extractor| {
        let mut want = vec![0u64; 24 * 24 * 24];
        for (i, (r, &e)) in rays.iter().zip(&ex.fixed).enumerate() {
            if keep(i as u32) && in_search_sample(i as u32, 4) {
                volume.dda(r.origin, r.dir, |c| want[c] += e);
            }
        }
        want
    };
    assert_eq!(ex.grid, grid_of(&|_| true, &ex));
    assert!(ex.grid.iter().any(|&e| e > 0));
    // Without one, every line.
    let every = Extractor::new(&rays, volume, 1);
    let mut want = vec![0u64; 24 * 24 * 24];
    for (r, &e) in rays.iter().zip(&every.fixed) {
        volume.dda(r.origin, r.dir, |c| want[c] += e);
    }
    assert_eq!(every.grid, want);
    let gone: Vec<u32> = (0..rays.len() as u32).filter(|i| i % 3 == 1).collect();
    ex.remove(&gone, false);
    assert_eq!(ex.grid, grid_of(&|i| i % 3 != 1, &ex));
    assert_eq!(ex.pool.len(), rays.len() - gone.len());
    // The search sample loses the same rays.
    let sample = ex.sample.as_ref().unwrap();
    assert!(
        sample
            .idx
            .iter()
            .all(|&i| i % 3 != 1 && in_search_sample(i, 4))
    );
    let want = (0..rays.len() as u32)
        .filter(|&i| i % 3 != 1 && in_search_sample(i, 4))
        .count();
    assert_eq!(sample.len(), want);
    // Removed in place, on this thread: the same exact sums.
    let gone: Vec<u32> = (0..rays.len() as u32).filter(|i| i % 3 == 2).collect();
    ex.remove(&gone, true);
    assert_eq!(ex.grid, grid_of(&|i| i % 3 == 0, &ex));
}

/// A bundle focused at (0, 0, -1) from a disc at z = 1 (drawn from `Pcg::new(seed, stream)`),
/// among as many scattered rays ([`random_rays`] seeded `scatter`), with a volume and
/// thresholds for it.
fn focused_bundle(
    (seed, stream): (u64, u64),
    scatter: u64,
) -> (Vec<CausticRay>, Volume, Thresholds) {
    let mut rng = crate::sampling::Pcg::new(seed, stream);
    let mut rays = random_rays(20_000, scatter);
    for _ in 0..20_000 {
        let (r, phi) = (0.3 * rng.f32().sqrt(), std::f32::consts::TAU * rng.f32());
        let origin = Vec3::new(r * phi.cos(), r * phi.sin(), 1.0);
        let jitter = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.02 - 0.01;
        rays.push(CausticRay {
            origin,
            dir: (Vec3::new(0.0, 0.0, -1.0) + jitter - origin).normalize(),
            energy: Vec3::ONE,
        });
    }
    let volume = Volume::new(Vec3::ZERO, 3.0, 32);
    let th = Thresholds {
        distance: 0.1,
        cos_angle: 60f32.to_radians().cos(),
        max_iterations: 100,
    };
    (rays, volume, th)
}

#[test]
fn the_search_sample_takes_every_branch_alike_and_finds_the_same_bundle() {
    let strides = [128, 512, 905, 906, 1280].map(search_stride);
    assert_eq!(strides, [1, 1, 1, 2, 4]);
    // A quarter of the indices of every residue: a grid ray's tree of paths leaves its rays
    // in a fixed order, and no branch may be left out of the search.
    for r in 0..4u32 {
        let n = (0..40_000u32)
            .filter(|&i| i % 4 == r && in_search_sample(i, 4))
            .count();
        assert!((2300..2700).contains(&n), "residue {r}: {n} of 10000");
    }
    let (rays, volume, th) = focused_bundle((7, 3), 9);
    let [all, sampled] = [1, 4].map(|stride| {
        let ex = Extractor::new(&rays, volume, stride);
        ex.extract(ex.max_cell().unwrap(), &th, 1.0).unwrap()
    });
    assert!(all.members.len() > 15_000, "{}", all.members.len());
    assert!(all.axis.dot(sampled.axis) > (0.5f32).to_radians().cos());
    assert!(line_distance(all.origin, all.axis, sampled.origin, sampled.axis) < 0.005);
    let changed = symmetric_difference(&all.members, &sampled.members);
    assert!(changed * 100 < all.members.len(), "{changed}");
}

#[test]
fn removed_rays_left_in_the_columns_are_passed_over() {
    // A focused bundle among scattered rays; a few of its rays removed: extraction gives
    // the same bundle, bit for bit, whether the columns still hold them or not.
    let (rays, volume, th) = focused_bundle((5, 11), 3);
    for stride in [1, 4] {
        let mut lazy = Extractor::new(&rays, volume, stride);
        let first = lazy.extract(lazy.max_cell().unwrap(), &th, 1.0).unwrap();
        // One in 40 of the bundle's rays, and a few scattered ones.
        let gone: Vec<u32> = first
            .members
            .iter()
            .copied()
            .filter(|i| i % 40 == 7 || *i < 300)
            .collect();
        lazy.remove(&gone, false);
        assert!(lazy.dead > 0, "stride {stride}: the columns were compacted");
        let mut compacted = Extractor::new(&rays, volume, stride);
        compacted.remove(&gone, false);
        compacted.compact();
        assert_eq!(lazy.remaining_energy(), compacted.remaining_energy());
        let cell = lazy.max_cell().unwrap();
        assert_eq!(cell, compacted.max_cell().unwrap());
        let (a, b) = (
            lazy.extract(cell, &th, 1.0).unwrap(),
            compacted.extract(cell, &th, 1.0).unwrap(),
        );
        assert!(a.members.len() > 15_000, "{}", a.members.len());
        assert!(a.members.iter().all(|&i| lazy.alive[i as usize]));
        assert_eq!(a.members, b.members);
        assert_eq!((a.origin, a.axis), (b.origin, b.axis));
    }
}

#[test]
fn walks_stay_in_the_largest_volume() {
    // 256 cells a side: fixed-point coordinates and indices stay in range (debug builds
    // check the arithmetic for overflow), and every line's cells are face neighbours.
    let v = Volume::new(Vec3::ZERO, 1.0, MAX_CELLS as u32);
    let n = MAX_CELLS;
    for r in random_rays(300, 5) {
        let mut cells = Vec::new();
        v.dda(r.origin, r.dir, |c| cells.push(c));
        for w in cells.windows(2) {
            let coords = |c: usize| [c % n, (c / n) % n, c / (n * n)].map(|x| x as i64);
            let (a, b) = (coords(w[0]), coords(w[1]));
            let steps: i64 = (0..3).map(|k| (a[k] - b[k]).abs()).sum();
            assert_eq!(steps, 1);
        }
        assert!(cells.iter().all(|&c| c < n * n * n));
    }
}

#[test]
fn line_distance_of_skew_and_parallel_lines() {
    let d = line_distance(Vec3::new(0.0, 0.0, 1.0), Vec3::X, Vec3::ZERO, Vec3::Y);
    assert!((d - 1.0).abs() < 1e-6);
    let d = line_distance(Vec3::new(0.0, 0.0, 2.0), Vec3::Y, Vec3::ZERO, Vec3::Y);
    assert!((d - 2.0).abs() < 1e-6);
}
