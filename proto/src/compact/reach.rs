//! The reach of a view-dependent mesh (protocol 4's culled spheres) in a
//! few bytes: neighbouring spheres merged down to [`MAX_COMPACT_CULLED`],
//! then quantised inside their box with radii rounded up, so every decoded
//! sphere still holds the engine's (PROTOCOL.md, "Protocol 7", "Reach").

use super::{CompactReach, MAX_COMPACT_CULLED};

/// The sphere holding two spheres.
fn merge([a, b]: [[f64; 4]; 2]) -> [f64; 4] {
    let d = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
    if d + b[3] <= a[3] {
        return a;
    }
    if d + a[3] <= b[3] {
        return b;
    }
    let r = (d + a[3] + b[3]) / 2.0;
    let t = (r - a[3]) / d;
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
        r * (1.0 + 1e-12) + 1e-12,
    ]
}

/// Merges neighbouring spheres down to [`MAX_COMPACT_CULLED`] and quantises
/// them so every decoded sphere holds its source.
pub(super) fn compact_reach(spheres: &[[f64; 4]], clearance: Option<f64>) -> CompactReach {
    let mut s: Vec<[f64; 4]> = spheres
        .iter()
        .copied()
        .filter(|s| s.iter().all(|v| v.is_finite()))
        .collect();
    // Neighbours in the walk's order lie near each other: merge, round by
    // round, the neighbouring pairs whose union grows least (at most one
    // merge per sphere a round), so large spheres that a moving camera
    // would see into form only where they must.
    while s.len() > MAX_COMPACT_CULLED {
        let excess = s.len() - MAX_COMPACT_CULLED;
        let mut growth: Vec<(f64, usize)> = (0..s.len() - 1)
            .map(|k| (merge([s[k], s[k + 1]])[3] - s[k][3].max(s[k + 1][3]), k))
            .collect();
        growth.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut taken = vec![false; s.len()];
        let mut merges = 0;
        for &(_, k) in &growth {
            if merges == excess {
                break;
            }
            if !taken[k] && !taken[k + 1] {
                taken[k] = true;
                taken[k + 1] = true;
                s[k] = merge([s[k], s[k + 1]]);
                s[k + 1][3] = f64::NAN;
                merges += 1;
            }
        }
        s.retain(|v| !v[3].is_nan());
    }
    let lo = [0, 1, 2].map(|k| s.iter().map(|v| v[k] - v[3]).fold(f64::INFINITY, f64::min));
    let hi = [0, 1, 2].map(|k| s.iter().map(|v| v[k] + v[3]).fold(f64::NEG_INFINITY, f64::max));
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if s.is_empty() || !(extent.is_finite() && extent > 0.0) {
        return CompactReach {
            clearance,
            lo: [0.0; 3],
            unit: 1.0,
            culled: Vec::new(),
        };
    }
    let unit = extent / 32767.0;
    let culled = s
        .iter()
        .map(|v| {
            let q = |k: usize| ((v[k] - lo[k]) / unit).round().clamp(0.0, 65535.0);
            let (x, y, z) = (q(0), q(1), q(2));
            let moved = ((lo[0] + x * unit - v[0]).powi(2)
                + (lo[1] + y * unit - v[1]).powi(2)
                + (lo[2] + z * unit - v[2]).powi(2))
            .sqrt();
            let r = ((v[3] + moved) / unit * (1.0 + 1e-9)).ceil() + 1.0;
            [x as u16, y as u16, z as u16, r.min(65535.0) as u16]
        })
        .collect();
    CompactReach {
        clearance,
        lo,
        unit,
        culled,
    }
}
