//! The level of detail `render` and `loadtest` share on the command line.

use dmesh_client::loadtest::Detail;

/// The level of detail of `render` and `loadtest`: one of --tau (default 1
/// pixel), --epsilon, --max-triangles, --budget-ms; optionally --bits.
#[derive(clap::Args, Debug)]
pub struct DetailArgs {
    /// View-dependent tolerance in pixels (default 1).
    #[arg(long, conflicts_with_all = ["epsilon", "max_triangles", "budget_ms"])]
    pub tau: Option<f64>,
    /// Static tolerance in metres.
    #[arg(long, conflicts_with_all = ["max_triangles", "budget_ms"])]
    pub epsilon: Option<f64>,
    /// Triangle budget per answer, shared by its views (the server picks tau).
    #[arg(long, conflicts_with = "budget_ms")]
    pub max_triangles: Option<u32>,
    /// Extraction time budget per answer in milliseconds (the server picks tau).
    #[arg(long)]
    pub budget_ms: Option<f64>,
    /// Residual bit-depth of the depths (0..=16; exact f32 when absent).
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=16))]
    pub bits: Option<u8>,
    /// Most views per answer (server default 5).
    #[arg(long)]
    pub max_views: Option<u32>,
    /// How meshes travel: the compact stream (protocol 7, zstd) or protocol 5 bincode.
    #[arg(long, value_enum, default_value = "compact")]
    pub wire: dmesh_client::http::Wire,
}

impl DetailArgs {
    /// The level of detail asked for (`Lod::exactly_one`), tau 1 when none.
    pub fn detail(&self) -> anyhow::Result<Detail> {
        use dmesh_proto::Lod;
        // With none, tau 1 pixel; two are refused (clap refuses them first).
        let none =
            self.epsilon.is_none() && self.tau.is_none() && self.max_triangles.is_none() && self.budget_ms.is_none();
        let lod = if none {
            Lod::Tau(1.0)
        } else {
            Lod::exactly_one(self.epsilon, self.tau, self.max_triangles, self.budget_ms).map_err(anyhow::Error::msg)?
        };
        Ok(Detail {
            lod,
            bits: self.bits,
            max_views: self.max_views,
            wire: self.wire,
        })
    }
}
