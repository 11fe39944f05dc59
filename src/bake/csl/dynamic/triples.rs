//! §4.3: the CSL triples of each icosahedron face, built from the matches of its three edges
//! ([`face_triples`]).

use super::tracking::Match;

/// How much of a triple member's intensity image the interpolation adds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Share {
    /// None: the member lends its axis, origin and focus law only.
    None,
    /// Half: the member is in two pair triples of the face, one per edge of its corner.
    Half,
    /// All of it: the member is in one matched triple of the face.
    Full,
}

impl Share {
    pub fn fraction(self) -> f32 {
        match self {
            Share::None => 0.0,
            Share::Half => 0.5,
            Share::Full => 1.0,
        }
    }
}

/// One member of a triple: a CSL of the face's corner (index into the corner's real CSLs, then
/// its blacks) and the share of its image the interpolation adds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Member {
    pub csl: u16,
    pub image: Share,
}

/// CSLs of a face's three corners interpolated together (§4.3), in the face's corner order.
///
/// A *matched* triple (three CSLs matched with each other on the face's three edges, rule 1)
/// adds all of each member's image, with the geometry blended by the barycentric weights. Where
/// a face's matches do not close into such cycles, every match (x at corner i, y at corner j)
/// of the face becomes a *pair* triple adding half of x's and half of y's image; its member at
/// the third corner k is x's partner there, and `split` y's partner there, which share k's
/// weight in proportion wᵢ : wⱼ. Both are matches of the edges (i, k) and (j, k) themselves, so
/// on every edge the interpolated set depends on that edge's matches alone and the faces on
/// either side give the same CSLs (rule 2), and a corner's CSLs add exactly their images there
/// (rule 3). On a matched cycle the three pair triples it would give coincide with its matched
/// triple, which is why the matched triple is stored instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Triple {
    pub members: [Member; 3],
    /// For a pair triple, the second CSL at its third corner (the corner whose member adds no
    /// image).
    pub split: Option<u16>,
}

/// Members by corner: `m[0]` at corner `i`, `m[1]` at the next corner, `m[2]` at the one after.
fn placed(i: usize, m: [(u16, Share); 3]) -> [Member; 3] {
    let mut out = [Member {
        csl: 0,
        image: Share::None,
    }; 3];
    for (n, (csl, image)) in m.into_iter().enumerate() {
        out[(i + n) % 3] = Member { csl, image };
    }
    out
}

/// §4.3: the triples of one face from the matches of its three edges (see [`Triple`]).
/// `matches[e]` are the pairs of the face's edge e = (corner e, corner e+1 mod 3), oriented
/// that way; `len[k]` is the number of CSLs (real and black) at corner k; `lit(k, i)` whether
/// CSL i of corner k has an image. Every CSL of every corner has one match on each of its two
/// edges of the face (a black partner where no CSL matched). Returns the triples and how many
/// are matched triples.
pub(super) fn face_triples(
    matches: [&[Match]; 3],
    len: [usize; 3],
    lit: &dyn Fn(usize, u16) -> bool,
) -> (Vec<Triple>, u32) {
    // partner[k][i][0]: the partner of CSL i of corner k at the next corner (k+1), [1] at the
    // previous one (k+2).
    let mut partner: [Vec<[Option<u16>; 2]>; 3] = [
        vec![[None; 2]; len[0]],
        vec![[None; 2]; len[1]],
        vec![[None; 2]; len[2]],
    ];
    for (e, m) in matches.iter().enumerate() {
        let (k0, k1) = (e, (e + 1) % 3);
        for &(a, b, _) in m.iter() {
            partner[k0][a as usize][0] = Some(b);
            partner[k1][b as usize][1] = Some(a);
        }
    }
    let mut in_cycle: [Vec<bool>; 3] = [
        vec![false; len[0]],
        vec![false; len[1]],
        vec![false; len[2]],
    ];
    let mut triples = Vec::new();
    let mut cycles = 0u32;
    for a in 0..len[0] {
        let Some(b) = partner[0][a][0] else { continue };
        let Some(c) = partner[1][b as usize][0] else {
            continue;
        };
        if partner[2][c as usize][0] != Some(a as u16) {
            continue;
        }
        in_cycle[0][a] = true;
        in_cycle[1][b as usize] = true;
        in_cycle[2][c as usize] = true;
        let ids = [a as u16, b, c];
        if (0..3).any(|k| lit(k, ids[k])) {
            triples.push(Triple {
                members: ids.map(|csl| Member {
                    csl,
                    image: Share::Full,
                }),
                split: None,
            });
        }
        cycles += 1;
    }
    // A CSL whose partners on both of its edges are blacks (made for it, so with no partner
    // on the face's third edge): its two pair triples would have the same members and weights,
    // so they are one triple adding all of its image.
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        for x in 0..len[i] {
            if in_cycle[i][x] {
                continue;
            }
            let (Some(y), Some(z)) = (partner[i][x][0], partner[i][x][1]) else {
                continue;
            };
            if partner[j][y as usize][0].is_some() || partner[k][z as usize][1].is_some() {
                continue;
            }
            in_cycle[i][x] = true;
            in_cycle[j][y as usize] = true;
            in_cycle[k][z as usize] = true;
            if lit(i, x as u16) {
                triples.push(Triple {
                    members: placed(
                        i,
                        [(x as u16, Share::Full), (y, Share::None), (z, Share::None)],
                    ),
                    split: None,
                });
            }
        }
    }
    for (e, m) in matches.iter().enumerate() {
        let (i, j) = (e, (e + 1) % 3);
        for &(x, y, _) in m.iter() {
            if in_cycle[i][x as usize] || in_cycle[j][y as usize] || !(lit(i, x) || lit(j, y)) {
                continue;
            }
            // x's partner at k is on edge (k, i): x's previous-corner partner; y's on (j, k):
            // y's next-corner partner. A black partner made on one edge has none on the
            // others: the other's partner stands in (its weight only matters where the black's
            // corner has weight, and a black adds no light there).
            let (zx, zy) = (partner[i][x as usize][1], partner[j][y as usize][0]);
            let (Some(zx), Some(zy)) = (zx.or(zy), zy.or(zx)) else {
                continue;
            };
            triples.push(Triple {
                members: placed(i, [(x, Share::Half), (y, Share::Half), (zx, Share::None)]),
                split: Some(zy),
            });
        }
    }
    (triples, cycles)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every real CSL of a corner adds exactly all its image in a face (rule 3), whatever the
    /// matching; a face whose matches close into cycles gets exactly those cycles as matched
    /// triples (rule 1); a pair triple's geometry-only members are the partners of its image
    /// members on the face's other edges (what makes rule 2 hold).
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn triples_count_every_csl_once_and_keep_cycles() {
        let all = |_: usize, _: u16| true;
        // Cycles: corner k's CSL i matched with CSL i of the next corner.
        let m: Vec<Match> = (0..4).map(|i| (i, i, i as f32)).collect();
        let (t, cycles) = face_triples([&m, &m, &m], [4, 4, 4], &all);
        assert_eq!((t.len(), cycles), (4, 4));
        assert!(t.iter().all(|t| {
            t.split.is_none()
                && t.members
                    .iter()
                    .all(|m| m.image == Share::Full && m.csl == t.members[0].csl)
        }));

        // Scrambled matches with blacks (indices ≥ the real counts).
        let mut seed = 3u32;
        for _ in 0..200 {
            let mut rnd = |n: usize| {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                (seed >> 8) as usize % n
            };
            let real = [1 + rnd(6), 1 + rnd(6), 1 + rnd(6)];
            // Per edge a random bijection between its ends, padded with blacks.
            let mut len = real;
            let mut edges: Vec<Vec<Match>> = Vec::new();
            for e in 0..3 {
                let (k0, k1) = (e, (e + 1) % 3);
                let mut b: Vec<usize> = (0..real[k1]).collect();
                for i in (1..b.len()).rev() {
                    b.swap(i, rnd(i + 1));
                }
                let mut pairs = Vec::new();
                for i in 0..real[k0].max(real[k1]) {
                    let a = if i < real[k0] {
                        i as u16
                    } else {
                        len[k0] += 1;
                        len[k0] as u16 - 1
                    };
                    let c = if i < real[k1] {
                        b[i] as u16
                    } else {
                        len[k1] += 1;
                        len[k1] as u16 - 1
                    };
                    pairs.push((a, c, rnd(100) as f32));
                }
                edges.push(pairs);
            }
            let lit = |k: usize, i: u16| (i as usize) < real[k];
            let (t, _) = face_triples([&edges[0], &edges[1], &edges[2]], len, &lit);
            for k in 0..3 {
                for i in 0..real[k] {
                    let share: f32 = t
                        .iter()
                        .filter(|t| t.members[k].csl as usize == i)
                        .map(|t| t.members[k].image.fraction())
                        .sum();
                    assert_eq!(share, 1.0, "corner {k} CSL {i}: {t:?}");
                }
                assert!(t.iter().all(|t| (t.members[k].csl as usize) < len[k]));
            }
            let partner = |e: usize, a: u16| edges[e].iter().find(|m| m.0 == a).map(|m| m.1);
            let partner_back = |e: usize, b: u16| edges[e].iter().find(|m| m.1 == b).map(|m| m.0);
            for tr in t.iter().filter(|t| t.split.is_some()) {
                let k = (0..3)
                    .find(|&k| tr.members[k].image == Share::None)
                    .unwrap();
                let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                // x at i: its partner at k is on edge (k, i) = edge k, x at its second end; y at
                // j: on edge (j, k) = edge j, y at its first end. A black has only one of them.
                let (px, py) = (
                    partner_back(k, tr.members[i].csl),
                    partner(j, tr.members[j].csl),
                );
                assert_eq!(px.or(py), Some(tr.members[k].csl));
                assert_eq!(py.or(px), tr.split);
                // x and y are matched on edge (i, j) = edge i.
                assert_eq!(partner(i, tr.members[i].csl), Some(tr.members[j].csl));
            }
        }
    }
}
