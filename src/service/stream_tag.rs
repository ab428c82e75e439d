//! Names of compact responses (protocol 7) that a server can act on
//! without remembering clients (DESIGN.md "The compact stream": stateless).
//!
//! A compact response's ETag states what determines it: the stored view's
//! version, the request's level of detail and a hash of its camera, and the
//! depth planes it carries, and the stream's version:
//! `"<view etag>.<lod><camera>.p<planes>.v7"`, with `<lod>` one of `e<bits>`,
//! `t<bits>` (the f64 bits of epsilon or tau, hex) or `n<max triangles>`,
//! `<camera>` empty or `c<hash>`, and `<planes>` a count or `a` for all
//! (a tag of another version names a mesh of other rules: ignored). A
//! request naming a held ETag of the same view version, level of detail and
//! camera gets only the planes it lacks; one of the same view version with
//! another level of detail or camera gets the change from it, the server
//! deriving the held mesh again from the tag (and the held camera the
//! request gives, which must hash to the tag's); any other held ETag is
//! ignored and the whole mesh is sent. A time budget (`budget_ms`) depends
//! on the server's measured rate, so its answers have no ETag.

use dmesh_engine::camera::Camera;
use dmesh_engine::render_plan::Ask;
use dmesh_proto::Lod as WireLod;

/// The tag's last field: the version of the compact stream whose rules
/// made the mesh it names.
const VERSION: &str = ".v7";

/// What a compact response is, parsed from or written to its ETag.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StreamTag {
    /// The stored view's ETag without its quotes.
    view: String,
    /// Level of detail and camera.
    mesh: String,
    /// Depth planes carried: `None` for all.
    pub planes: Option<u8>,
}

impl StreamTag {
    /// The tag of the answer to `ask` from the view stored as `view_etag`;
    /// `None` for a time budget.
    pub fn new(view_etag: &str, ask: &Ask) -> Option<Self> {
        let lod = match ask.wire_lod() {
            WireLod::Epsilon(e) => format!("e{:x}", e.to_bits()),
            WireLod::Tau(t) => format!("t{:x}", t.to_bits()),
            WireLod::MaxTriangles(n) => format!("n{n}"),
            WireLod::BudgetMs(_) => return None,
        };
        let camera = ask.camera().map_or(String::new(), |c| {
            let wire: dmesh_proto::Camera = c.into();
            let bytes = dmesh_proto::to_bincode(&wire).unwrap_or_default();
            format!("c{:016x}", fnv1a(&bytes))
        });
        Some(Self {
            view: view_etag.trim_matches('"').to_string(),
            mesh: format!("{lod}{camera}"),
            planes: ask.bits(),
        })
    }

    /// Parses an ETag this module wrote; `None` for anything else.
    pub fn parse(etag: &str) -> Option<Self> {
        let inner = etag.trim().strip_prefix('"')?.strip_suffix('"')?;
        let inner = inner.strip_suffix(VERSION)?;
        let (rest, planes) = inner.rsplit_once(".p")?;
        let (view, mesh) = rest.rsplit_once('.')?;
        let planes = match planes {
            "a" => None,
            n => Some(n.parse().ok()?),
        };
        (!view.is_empty() && !mesh.is_empty()).then(|| Self {
            view: view.to_string(),
            mesh: mesh.to_string(),
            planes,
        })
    }

    /// The ETag, quoted.
    pub fn etag(&self) -> String {
        let planes = self.planes.map_or("a".to_string(), |p| p.to_string());
        format!("\"{}.{}.p{planes}{VERSION}\"", self.view, self.mesh)
    }

    /// The same tag with `planes`.
    pub fn with_planes(&self, planes: Option<u8>) -> Self {
        Self { planes, ..self.clone() }
    }

    /// True when `held` names the same mesh (view version, level of detail, camera).
    pub fn same_mesh(&self, held: &Self) -> bool {
        self.view == held.view && self.mesh == held.mesh
    }

    /// True when `held` names a mesh of the same view version.
    pub fn same_view(&self, held: &Self) -> bool {
        self.view == held.view
    }

    /// The request that made the mesh this tag names, given the camera it
    /// was made for: `None` unless the tag is exactly that request's.
    pub fn ask(&self, view_etag: &str, camera: Option<Camera>) -> Option<Ask> {
        // `<lod>` then, when a camera was given, `c` and 16 hex digits.
        let hashed = self.mesh.len() > 17 && self.mesh.as_bytes()[self.mesh.len() - 17] == b'c';
        let lod = if hashed {
            &self.mesh[..self.mesh.len() - 17]
        } else {
            &self.mesh[..]
        };
        let number = |s: &str| u64::from_str_radix(s, 16).ok().map(f64::from_bits);
        let lod = match lod.split_at_checked(1)? {
            ("e", x) => WireLod::Epsilon(number(x)?),
            ("t", x) => WireLod::Tau(number(x)?),
            ("n", n) => WireLod::MaxTriangles(n.parse().ok()?),
            _ => return None,
        };
        let ask = Ask::new(lod, camera, self.planes).ok()?;
        (Self::new(view_etag, &ask).as_ref() == Some(self)).then_some(ask)
    }
}

/// 64-bit FNV-1a: a stable hash of the camera's bytes (not for security:
/// a forged tag only gets its sender the planes of another camera's mesh
/// of the same view, which it could have asked for).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_round_trip_and_name_their_mesh() {
        let cam = Camera::perspective(8, 6, 8.0, 8.0, 3.5, 2.5).unwrap();
        let tau = Ask::new(WireLod::Tau(1.5), Some(cam), Some(4)).unwrap();
        let t = StreamTag::new("\"abc-1\"", &tau).unwrap();
        assert_eq!(StreamTag::parse(&t.etag()), Some(t.clone()));
        let all = t.with_planes(None);
        assert!(all.etag().ends_with(".pa.v7\""), "{}", all.etag());
        assert_eq!(super::VERSION, format!(".v{}", dmesh_proto::COMPACT_VERSION));
        assert_eq!(StreamTag::parse(&all.etag()), Some(all.clone()));
        assert!(t.same_mesh(&all));
        let mut moved = cam;
        moved.translation.x += 0.01;
        let other = StreamTag::new("\"abc-1\"", &Ask::new(WireLod::Tau(1.5), Some(moved), Some(4)).unwrap()).unwrap();
        assert!(!t.same_mesh(&other));
        let newer = StreamTag::new("\"abc-2\"", &tau).unwrap();
        assert!(!t.same_mesh(&newer));
        // A tag gives back its request, given the camera it hashed.
        assert_eq!(t.ask("\"abc-1\"", Some(cam)), Some(tau));
        assert_eq!(t.ask("\"abc-1\"", Some(moved)), None);
        assert_eq!(t.ask("\"abc-1\"", None), None);
        assert_eq!(t.ask("\"abc-2\"", Some(cam)), None);
        for lod in [WireLod::Epsilon(0.0125), WireLod::MaxTriangles(5000)] {
            let ask = Ask::new(lod, None, None).unwrap();
            let tag = StreamTag::new("\"v\"", &ask).unwrap();
            assert_eq!(StreamTag::parse(&tag.etag()).unwrap().ask("\"v\"", None), Some(ask));
        }
        let budget = Ask::new(WireLod::MaxTriangles(70), Some(cam), Some(3)).unwrap();
        let tag = StreamTag::new("\"v\"", &budget).unwrap();
        assert_eq!(tag.ask("\"v\"", Some(cam)), Some(budget));
        assert!(StreamTag::new("\"v\"", &Ask::new(WireLod::BudgetMs(1.0), None, None).unwrap()).is_none());
        for bad in ["", "\"\"", "abc", "\"v.e1.px\"", "\".e1.p3\"", "\"v.p3\""] {
            assert_eq!(StreamTag::parse(bad), None, "{bad}");
        }
    }
}
