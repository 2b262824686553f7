//! BC6H (unsigned, `BC6H_UF16`) one-region blocks written by hand, for the blocks whose light a
//! general encoder does not hold: modes 11–14 of the format (Direct3D's numbering), one pair
//! of endpoints per channel and a 4-bit index per texel.
//!
//! | mode | code | endpoint A | endpoint B |
//! |---|---|---|---|
//! | 11 | `00011` | 10 bits | 10 bits |
//! | 12 | `00111` | 11 bits | A + a signed 9-bit delta |
//! | 13 | `01011` | 12 bits | A + a signed 8-bit delta |
//! | 14 | `01111` | 16 bits | A + a signed 4-bit delta |
//!
//! A texel decodes to `((A·(64 − w) + B·w + 32) >> 6) · 31 >> 6` as a half float's bits, with
//! A and B unquantised to 16 bits and `w` the index's weight, so every value this module
//! predicts for a block is the value a decoder gives (tested against `bcdec_rs`).
//!
//! [`encode_holding_power`] searches, per mode, the endpoints and indices of a block for the
//! decoded texels nearest the source in log space among those whose power (Σ texel · weight)
//! is within a tolerance of a target, per channel.

use exr::prelude::f16;

/// The weights of the 16 indices (out of 64).
const WEIGHTS: [i32; 16] = [0, 4, 9, 13, 17, 21, 26, 30, 34, 38, 43, 47, 51, 55, 60, 64];

/// One of the one-region modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mode {
    /// Direct3D's number (11–14).
    pub number: u8,
    code: u8,
    /// Bits of endpoint A.
    base: u32,
    /// Bits of B's signed delta from A; `None`: B is stored whole.
    delta: Option<u32>,
}

/// The four one-region modes, coarsest endpoints (widest range) first.
pub const MODES: [Mode; 4] = [
    Mode {
        number: 11,
        code: 0b00011,
        base: 10,
        delta: None,
    },
    Mode {
        number: 12,
        code: 0b00111,
        base: 11,
        delta: Some(9),
    },
    Mode {
        number: 13,
        code: 0b01011,
        base: 12,
        delta: Some(8),
    },
    Mode {
        number: 14,
        code: 0b01111,
        base: 16,
        delta: Some(4),
    },
];

impl Mode {
    fn max(&self) -> i32 {
        (1 << self.base) - 1
    }

    /// Endpoint `e` unquantised to 16 bits.
    fn unquantize(&self, e: i32) -> i32 {
        if self.base >= 15 {
            e
        } else if e == 0 {
            0
        } else if e == self.max() {
            0xFFFF
        } else {
            ((e << 16) + 0x8000) >> self.base
        }
    }

    /// The endpoint whose unquantised value is nearest `u` (a 16-bit value, continuous).
    fn quantize(&self, u: f64) -> i32 {
        let step = (1u32 << (16 - self.base.min(16))) as f64;
        let e = ((u - step / 2.0) / step).round() as i32;
        let e = e.clamp(0, self.max());
        // The nearest of e and its neighbours (0 and the top unquantise specially).
        (e - 1..=e + 1)
            .filter(|&c| (0..=self.max()).contains(&c))
            .min_by(|&a, &b| {
                (self.unquantize(a) as f64 - u)
                    .abs()
                    .total_cmp(&(self.unquantize(b) as f64 - u).abs())
            })
            .unwrap_or(e)
    }

    /// Whether B may be stored against A.
    fn fits(&self, a: i32, b: i32) -> bool {
        if !(0..=self.max()).contains(&a) || !(0..=self.max()).contains(&b) {
            return false;
        }
        match self.delta {
            None => true,
            Some(d) => {
                let diff = b - a;
                diff >= -(1 << (d - 1)) && diff < (1 << (d - 1))
            }
        }
    }
}

/// The 16 values (f32) a channel with endpoints `a`, `b` decodes to, index by index.
fn ladder(m: &Mode, a: i32, b: i32) -> [f32; 16] {
    let (ua, ub) = (m.unquantize(a), m.unquantize(b));
    std::array::from_fn(|i| {
        let w = WEIGHTS[i];
        let v = (ua * (64 - w) + ub * w + 32) >> 6;
        f16::from_bits(((v * 31) >> 6) as u16).to_f32()
    })
}

/// A half float's bits for `x` ≥ 0 as a continuous value, times 64/31: the unquantised
/// 16-bit value that decodes to `x`.
fn unquantized_of(x: f32) -> f64 {
    let h = f16::from_f32(x.max(0.0)).to_bits() as f64;
    h * 64.0 / 31.0
}

/// A block as encoded here: endpoints per channel and the texels' indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    pub mode: Mode,
    /// `[channel][A, B]`.
    pub ends: [[i32; 2]; 3],
    /// Rows first.
    pub index: [u8; 16],
}

/// A little-endian bit writer over 128 bits.
struct Bits {
    v: u128,
    at: u32,
}

impl Bits {
    fn put(&mut self, value: u32, n: u32) {
        self.v |= ((value as u128) & ((1u128 << n) - 1)) << self.at;
        self.at += n;
    }
}

fn reverse(v: u32, n: u32) -> u32 {
    (0..n).fold(0, |r, i| r | (((v >> i) & 1) << (n - 1 - i)))
}

impl Block {
    /// The decoded texels, rows first.
    pub fn decode(&self) -> [[f32; 3]; 16] {
        let l: [[f32; 16]; 3] =
            std::array::from_fn(|k| ladder(&self.mode, self.ends[k][0], self.ends[k][1]));
        std::array::from_fn(|i| std::array::from_fn(|k| l[k][self.index[i] as usize]))
    }

    /// The 16 bytes; `None` where B cannot be stored against A.  The first texel's index is
    /// stored with 3 bits, so a block whose first index is 8 or more is written with its
    /// endpoints swapped and its indices mirrored (the same texels).
    pub fn to_bytes(&self) -> Option<[u8; 16]> {
        let m = &self.mode;
        let (ends, index) = if self.index[0] >= 8 {
            (self.ends.map(|[a, b]| [b, a]), self.index.map(|i| 15 - i))
        } else {
            (self.ends, self.index)
        };
        if !ends.iter().all(|&[a, b]| m.fits(a, b)) {
            return None;
        }
        let mut w = Bits { v: 0, at: 0 };
        w.put(m.code as u32, 5);
        for e in &ends {
            w.put(e[0] as u32, 10);
        }
        for e in &ends {
            let (a, b) = (e[0] as u32, e[1] as u32);
            match m.delta {
                None => w.put(b, 10),
                Some(d) => {
                    w.put(b.wrapping_sub(a), d);
                    let high = a >> 10;
                    match m.base {
                        11 => w.put(high, 1),
                        n => w.put(reverse(high, n - 10), n - 10),
                    }
                }
            }
        }
        debug_assert_eq!(w.at, 65);
        w.put(index[0] as u32, 3);
        for &i in &index[1..] {
            w.put(i as u32, 4);
        }
        debug_assert_eq!(w.at, 128);
        Some(w.v.to_le_bytes())
    }
}

/// What the search aims at: the block's power per channel and the scale its error is
/// measured against (the error of channel k is |power − target| / scale; scale 0: the channel
/// is not measured).
pub struct Aim {
    pub target: [f64; 3],
    pub scale: [f64; 3],
    pub tolerance: f64,
}

/// The texels in the order of their projection on the principal axis of `u` (power
/// iteration on the covariance, started on the axis of the widest channel).
fn principal_order(u: &[[f64; 3]; 16]) -> [usize; 16] {
    let mean: [f64; 3] = std::array::from_fn(|k| u.iter().map(|t| t[k]).sum::<f64>() / 16.0);
    let mut cov = [[0.0f64; 3]; 3];
    for t in u {
        for a in 0..3 {
            for b in 0..3 {
                cov[a][b] += (t[a] - mean[a]) * (t[b] - mean[b]);
            }
        }
    }
    let widest = (0..3)
        .max_by(|&a, &b| cov[a][a].total_cmp(&cov[b][b]))
        .unwrap_or(0);
    let mut v = [0.0f64; 3];
    v[widest] = 1.0;
    for _ in 0..12 {
        let w: [f64; 3] = std::array::from_fn(|a| (0..3).map(|b| cov[a][b] * v[b]).sum());
        let n = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n <= 0.0 {
            break;
        }
        v = w.map(|x| x / n);
    }
    let proj = |t: &[f64; 3]| (0..3).map(|k| (t[k] - mean[k]) * v[k]).sum::<f64>();
    let mut order: [usize; 16] = std::array::from_fn(|i| i);
    order.sort_by(|&a, &b| proj(&u[a]).total_cmp(&proj(&u[b])).then(a.cmp(&b)));
    order
}

/// The state of one mode's search.
#[derive(Clone)]
struct Search<'a> {
    m: Mode,
    weights: &'a [f64],
    aim: &'a Aim,
    /// ln(1 + texel), per texel and channel.
    lt: [[f64; 3]; 16],
    ends: [[i32; 2]; 3],
    ladders: [[f32; 16]; 3],
    /// ln(1 + value) of the ladders.
    ll: [[f64; 16]; 3],
    index: [u8; 16],
}

fn ln1p_all(l: &[f32; 16]) -> [f64; 16] {
    l.map(|v| (v as f64).ln_1p())
}

impl Search<'_> {
    fn set_ends(&mut self, k: usize, e: [i32; 2]) {
        self.ends[k] = e;
        self.ladders[k] = ladder(&self.m, e[0], e[1]);
        self.ll[k] = ln1p_all(&self.ladders[k]);
    }

    /// Squared log error of texel `i` at index `j`, channel `k`.
    #[inline]
    fn sq(&self, k: usize, i: usize, j: u8) -> f64 {
        let d = self.ll[k][j as usize] - self.lt[i][k];
        d * d
    }

    /// Index changes while the block misses (up to `nudges`), its endpoints settled again
    /// every few, and at the end.
    fn refine(&mut self, nudges: usize) {
        let mut n = 0;
        while self.error() > self.aim.tolerance && n < nudges && self.nudge() {
            n += 1;
            if n % 8 == 0 {
                for k in 0..3 {
                    self.settle_ends(k, 1);
                }
            }
        }
        for k in 0..3 {
            self.settle_ends(k, 1);
        }
        // A channel still missing: its endpoints searched farther.
        for k in 0..3 {
            if self.channel_error(k, self.power(k)) > self.aim.tolerance {
                self.settle_ends(k, FAR_REACH);
            }
        }
    }

    fn power(&self, k: usize) -> f64 {
        (0..16)
            .map(|i| self.ladders[k][self.index[i] as usize] as f64 * self.weights[i])
            .sum()
    }

    fn channel_error(&self, k: usize, p: f64) -> f64 {
        if self.aim.scale[k] > 0.0 {
            (p - self.aim.target[k]).abs() / self.aim.scale[k]
        } else {
            0.0
        }
    }

    fn error(&self) -> f64 {
        (0..3)
            .map(|k| self.channel_error(k, self.power(k)))
            .fold(0.0, f64::max)
    }

    fn log_cost(&self) -> f64 {
        (0..16)
            .map(|i| (0..3).map(|k| self.sq(k, i, self.index[i])).sum::<f64>())
            .sum()
    }

    /// Each texel's index: the one nearest its texel in log space.
    fn nearest_indices(&mut self) {
        for i in 0..16 {
            let c = |j: u8| (0..3).map(|k| self.sq(k, i, j)).sum::<f64>();
            self.index[i] = (0..16u8)
                .min_by(|&a, &b| c(a).total_cmp(&c(b)))
                .unwrap_or(0);
        }
    }

    /// Channel k's endpoints moved within `reach` steps of where they are: the pair whose
    /// power error is within the tolerance with the least log error, or else the least power
    /// error.
    fn settle_ends(&mut self, k: usize, reach: i32) {
        let [a0, b0] = self.ends[k];
        let mut best: Option<(bool, f64, [i32; 2], [f32; 16])> = None;
        for da in -reach..=reach {
            for db in -reach..=reach {
                let (a, b) = (a0 + da, b0 + db);
                if !self.m.fits(a, b) || !self.m.fits(b, a) {
                    continue;
                }
                let l = ladder(&self.m, a, b);
                let p: f64 = (0..16)
                    .map(|i| l[self.index[i] as usize] as f64 * self.weights[i])
                    .sum();
                let e = self.channel_error(k, p);
                let ok = e <= self.aim.tolerance;
                let score = if ok {
                    (0..16)
                        .map(|i| {
                            let d = (l[self.index[i] as usize] as f64).ln_1p() - self.lt[i][k];
                            d * d
                        })
                        .sum()
                } else {
                    e
                };
                let better = match &best {
                    None => true,
                    Some((bok, bs, ..)) => (ok && !bok) || (ok == *bok && score < *bs),
                };
                if better {
                    best = Some((ok, score, [a, b], l));
                }
            }
        }
        if let Some((_, _, e, _)) = best {
            self.set_ends(k, e);
        }
    }

    /// One texel's index changed, the change that lowers the block's error most (among
    /// changes that bring it within the tolerance: the one of least log error); returns
    /// whether one did.
    fn nudge(&mut self) -> bool {
        let now = self.error();
        let p: [f64; 3] = std::array::from_fn(|k| self.power(k));
        let mut best: Option<(f64, f64, f64, usize, u8)> = None;
        for i in 0..16 {
            if self.weights[i] == 0.0 {
                continue;
            }
            for j in 0..16u8 {
                if j == self.index[i] {
                    continue;
                }
                let e = (0..3)
                    .map(|k| {
                        let dv = (self.ladders[k][j as usize]
                            - self.ladders[k][self.index[i] as usize])
                            as f64;
                        self.channel_error(k, p[k] + dv * self.weights[i])
                    })
                    .fold(0.0, f64::max);
                let cost: f64 = (0..3)
                    .map(|k| self.sq(k, i, j) - self.sq(k, i, self.index[i]))
                    .sum();
                // Within the tolerance: the least log error; otherwise the most error
                // removed per log error added.
                let gain = (now - e) / (cost.max(0.0) + 1e-9);
                let better = match best {
                    None => true,
                    Some((be, bc, bg, ..)) => {
                        let (ok, bok) = (e <= self.aim.tolerance, be <= self.aim.tolerance);
                        if ok && bok {
                            cost < bc
                        } else if ok != bok {
                            ok
                        } else {
                            gain > bg
                        }
                    }
                };
                if better {
                    best = Some((e, cost, gain, i, j));
                }
            }
        }
        match best {
            Some((e, _, _, i, j)) if e < now => {
                self.index[i] = j;
                true
            }
            _ => false,
        }
    }
}

/// The reach of the endpoint search (steps either side), and the most index nudges.
const END_REACH: i32 = 3;
const NUDGES: usize = 48;
const FAR_REACH: i32 = 8;

/// The one-region block of `texels` (16, rows first, each channel ≥ 0 and within BC6H's
/// range) whose power with `weights` is nearest `aim` (within its tolerance: the one of least
/// log error), over the modes whose endpoints can span the block; with its power error.
pub fn encode_holding_power(texels: &[[f32; 3]], weights: &[f64], aim: &Aim) -> (Block, f64) {
    assert!(texels.len() == 16 && weights.len() == 16);
    let mut best: Option<(Block, f64, f64)> = None;
    for m in MODES {
        // Endpoints at the two ends of the block's texels along their principal axis (in
        // the unquantised, nearly logarithmic values; a channel that falls as another rises
        // runs the other way), the few texels nearest each end tried (a black texel need not
        // spend the ladder), and at each channel's own darkest and brightest value: the pair
        // of least log error with each texel at its nearest index.
        let us: [[f64; 3]; 16] =
            std::array::from_fn(|i| std::array::from_fn(|k| unquantized_of(texels[i][k])));
        let order = principal_order(&us);
        let sorted: [Vec<f64>; 3] = std::array::from_fn(|k| {
            let mut u: Vec<f64> = us.iter().map(|t| t[k]).collect();
            u.sort_by(f64::total_cmp);
            u
        });
        let mut starts: Vec<[[i32; 2]; 3]> = Vec::with_capacity(30);
        for lo in 0..5 {
            for hi in [15, 14, 13] {
                starts.push(std::array::from_fn(|k| {
                    [m.quantize(us[order[lo]][k]), m.quantize(us[order[hi]][k])]
                }));
                starts.push(std::array::from_fn(|k| {
                    [m.quantize(sorted[k][lo]), m.quantize(sorted[k][hi])]
                }));
            }
        }
        let lt: [[f64; 3]; 16] =
            std::array::from_fn(|i| std::array::from_fn(|k| (texels[i][k] as f64).ln_1p()));
        let mut start: Option<(f64, Search)> = None;
        {
            for ends in starts {
                if !ends.iter().all(|&[a, b]| m.fits(a, b) && m.fits(b, a)) {
                    continue;
                }
                let ladders = std::array::from_fn(|k| ladder(&m, ends[k][0], ends[k][1]));
                let mut s = Search {
                    m,
                    weights,
                    aim,
                    lt,
                    ends,
                    ladders,
                    ll: std::array::from_fn(|k| ln1p_all(&ladders[k])),
                    index: [0; 16],
                };
                s.nearest_indices();
                let c = s.log_cost();
                if start.as_ref().is_none_or(|(bc, _)| c < *bc) {
                    start = Some((c, s));
                }
            }
        }
        let Some((_, mut s)) = start else {
            continue;
        };
        for k in 0..3 {
            s.settle_ends(k, END_REACH);
        }
        s.refine(NUDGES);
        let (e, c) = (s.error(), s.log_cost());
        let block = Block {
            mode: m,
            ends: s.ends,
            index: s.index,
        };
        if block.to_bytes().is_none() {
            continue;
        }
        let better = match &best {
            None => true,
            Some((_, be, bc)) => {
                let (ok, bok) = (e <= aim.tolerance, *be <= aim.tolerance);
                if ok && bok {
                    c < *bc
                } else {
                    e < *be
                }
            }
        };
        if better {
            best = Some((block, e, c));
        }
    }
    let (b, e, _) = best.expect("mode 11 spans any block within BC6H's range");
    (b, e)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal weights for a block's texels, and the aim of holding its mean power per channel
    /// within 0.1 %.
    fn even_aim(texels: &[[f32; 3]; 16]) -> ([f64; 16], Aim) {
        let target: [f64; 3] =
            std::array::from_fn(|k| texels.iter().map(|t| t[k] as f64 / 16.0).sum());
        let aim = Aim {
            target,
            scale: target,
            tolerance: 1e-3,
        };
        ([1.0 / 16.0; 16], aim)
    }

    fn decode_bytes(b: &[u8; 16]) -> Vec<[f32; 3]> {
        let mut half = [0u16; 48];
        bcdec_rs::bc6h_half(b, &mut half, 12, false);
        half.chunks_exact(3)
            .map(|p| [0, 1, 2].map(|k| f16::from_bits(p[k]).to_f32()))
            .collect()
    }

    /// A small deterministic generator (no dependency on a seed crate's stream).
    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*s >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn every_mode_decodes_as_predicted_by_an_independent_decoder() {
        let mut seed = 7u64;
        let mut seen = [0usize; 4];
        for n in 0..4000 {
            let m = MODES[n % 4];
            let mut ends = [[0i32; 2]; 3];
            for e in ends.iter_mut() {
                let a = (lcg(&mut seed) * (m.max() + 1) as f64) as i32;
                let reach = match m.delta {
                    None => m.max() + 1,
                    Some(d) => 1 << (d - 1),
                };
                let b =
                    (a + ((lcg(&mut seed) * 2.0 - 1.0) * reach as f64) as i32).clamp(0, m.max());
                *e = [a, b];
            }
            let index: [u8; 16] = std::array::from_fn(|_| (lcg(&mut seed) * 16.0) as u8);
            let block = Block {
                mode: m,
                ends,
                index,
            };
            let Some(bytes) = block.to_bytes() else {
                continue;
            };
            seen[n % 4] += 1;
            let ours = block.decode();
            let theirs = decode_bytes(&bytes);
            for i in 0..16 {
                assert_eq!(ours[i], theirs[i], "mode {} texel {i}: {block:?}", m.number);
            }
        }
        assert!(seen.iter().all(|&s| s > 500), "{seen:?}");
    }

    #[test]
    fn a_bright_texel_beside_dim_ones_keeps_the_blocks_power_within_a_step() {
        // A sun-like texel of 10,000 in a block of values near 1: ten-bit endpoints alone
        // quantise it in steps of about 3 %.
        let mut texels = [[1.0f32, 0.9, 0.8]; 16];
        texels[5] = [9876.5, 8123.4, 7001.0];
        texels[6] = [120.0, 100.0, 90.0];
        let (weights, aim) = even_aim(&texels);
        let target = aim.target;
        let (block, err) = encode_holding_power(&texels, &weights, &aim);
        // Per channel within half a percent: its indices are shared, and the sun's ten-bit
        // endpoints step by 3 %, so channels missing in opposite directions cannot all be
        // met more closely inside the block (what remains is carried to its neighbours).
        assert!(err <= 5e-3, "error {err}");
        let bytes = block.to_bytes().unwrap();
        let dec = decode_bytes(&bytes);
        for k in 0..3 {
            let p: f64 = dec.iter().map(|t| t[k] as f64 / 16.0).sum();
            assert!(
                (p / target[k] - 1.0).abs() <= 5e-3,
                "channel {k}: {p} vs {}",
                target[k]
            );
        }
        // The sun stays the sun.
        assert!(dec[5][0] > 9000.0 && dec[0][0] < 2.0, "{dec:?}");
    }

    #[test]
    fn a_channel_that_falls_as_another_rises_is_held() {
        // A block of an HDRI's level whose blue source (to 3,285) sits where red and green
        // are black, beside texels red and green where blue is dim.
        let texels: [[f32; 3]; 16] = [
            [4.08, 3.78, 9.77],
            [4.77, 4.49, 8.69],
            [5.77, 5.50, 4.35],
            [5.99, 5.84, 3.86],
            [0.031, 0.026, 508.7],
            [0.123, 0.106, 366.6],
            [3.78, 3.20, 10.9],
            [7.85, 7.08, 4.38],
            [0.0, 0.0, 3285.0],
            [0.0, 0.0, 2573.9],
            [6.43, 5.02, 56.2],
            [10.71, 8.91, 5.78],
            [1.09, 0.88, 198.1],
            [0.71, 0.55, 165.3],
            [5.33, 4.16, 20.68],
            [10.47, 8.74, 4.85],
        ];
        let (weights, aim) = even_aim(&texels);
        let (block, err) = encode_holding_power(&texels, &weights, &aim);
        // Within 1 % (red and green, black under the blue sun, share its index: one region
        // cannot hold them more closely; per-channel endpoints along the axis alone missed
        // by 2.2 %).
        assert!(err <= 1e-2, "error {err}: {block:?}");
        let dec = decode_bytes(&block.to_bytes().unwrap());
        // Blue's bright texels stay blue.
        assert!(dec[8][2] > 2000.0 && dec[8][0] < 1.0, "{dec:?}");
    }

    #[test]
    fn a_block_of_one_value_is_held_closely_by_the_wide_base_modes() {
        let texels = [[3.25f32, 2.5, 0.125]; 16];
        let weights = [1.0; 16];
        let target: [f64; 3] = std::array::from_fn(|k| 16.0 * texels[0][k] as f64);
        let aim = Aim {
            target,
            scale: target,
            tolerance: 1e-4,
        };
        let (block, err) = encode_holding_power(&texels, &weights, &aim);
        assert!(err <= 1e-4, "error {err} in mode {}", block.mode.number);
        assert!(block.mode.number >= 12);
    }
}
