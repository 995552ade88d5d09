//! Choosing the object's cluster: the one whose size and shape match the reference model.
//!
//! A single-view scan sees one side of the object: its two largest spans along the principal axes
//! (length and width) match the model's, but its thinnest span (depth along the view) is at most
//! the model's. The score of a cluster is therefore
//! `|ln(s₁/r₁)| + |ln(s₂/r₂)| + w · max(0, ln(s₃/r₃))` with `s` the cluster's spans and `r` the
//! model's (both sorted, decreasing); a cluster whose length or width differ from the model's by
//! more than the factor `max_span_ratio`, or whose thinnest span exceeds the model's by more, does
//! not fit. The lowest score wins. Without a reference the largest cluster is the object.

use crate::error::{Error, Result};
use crate::segment::cluster::Cluster;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Configuration of the cluster choice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SelectConfig {
    /// Largest factor between a cluster's span and the model's (length, width; thinnest span only
    /// when larger than the model's) for the cluster to fit.
    pub max_span_ratio: f64,
    /// Weight `w` of an excess thinnest span in the score.
    pub depth_weight: f64,
}

impl Default for SelectConfig {
    fn default() -> Self {
        SelectConfig {
            max_span_ratio: 1.6,
            depth_weight: 0.5,
        }
    }
}

impl SelectConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`select.…`).
    pub fn validate(&self) -> Result<()> {
        crate::config::require(
            self.max_span_ratio > 1.0 && self.max_span_ratio.is_finite(),
            "select.max_span_ratio",
            format!(
                "must be a finite number > 1, got {}",
                crate::config::shown(self.max_span_ratio)
            ),
        )?;
        crate::config::non_negative("select.depth_weight", self.depth_weight)
    }
}

/// The chosen cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Index of the chosen cluster in the slice given.
    pub index: usize,
    /// Score of every cluster (lower is better; `None` when it does not fit, or without a
    /// reference).
    pub scores: Vec<Option<f64>>,
}

/// The score of spans `s` against the model's `r` (both decreasing), or `None` if they do not fit.
pub fn span_score(s: &Vector3<f64>, r: &Vector3<f64>, cfg: &SelectConfig) -> Option<f64> {
    let lr = |a: f64, b: f64| (a.max(1e-9) / b.max(1e-9)).ln();
    let limit = cfg.max_span_ratio.ln();
    let (l1, l2, l3) = (lr(s[0], r[0]), lr(s[1], r[1]), lr(s[2], r[2]).max(0.0));
    (l1.abs() <= limit && l2.abs() <= limit && l3 <= limit)
        .then(|| l1.abs() + l2.abs() + cfg.depth_weight * l3)
}

/// Spans for a message, millimetre-rounded: `0.715×0.349×0.349`.
pub fn spans_text(s: &Vector3<f64>) -> String {
    format!("{:.3}×{:.3}×{:.3}", s[0], s[1], s[2])
}

/// Chooses the object's cluster among `clusters` (largest first), by its fit to the model's spans
/// `reference_spans` (decreasing, metres) or, without them, the largest.
///
/// # Errors
/// [`Error::Input`] for a bad configuration ([`SelectConfig::validate`]); [`Error::Failed`] (stage `select`) when there is
/// no cluster or none fits the reference.
pub fn select_cluster(
    clusters: &[Cluster],
    reference_spans: Option<&Vector3<f64>>,
    cfg: &SelectConfig,
) -> Result<Selection> {
    cfg.validate()?;
    if clusters.is_empty() {
        return Err(Error::failed("select", "no cluster above the seabed"));
    }
    let Some(r) = reference_spans else {
        return Ok(Selection {
            index: 0,
            scores: vec![None; clusters.len()],
        });
    };
    let scores: Vec<Option<f64>> = clusters
        .iter()
        .map(|c| span_score(&c.shape.spans, r, cfg))
        .collect();
    let best = scores
        .iter()
        .enumerate()
        .filter_map(|(i, s)| s.map(|s| (i, s)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((index, _)) => Ok(Selection { index, scores }),
        None => {
            let closest = clusters
                .iter()
                .take(5)
                .map(|c| spans_text(&c.shape.spans))
                .collect::<Vec<_>>()
                .join(", ");
            Err(Error::failed(
                "select",
                format!(
                    "no cluster fits the reference's {} m within a factor {} \
                     (largest clusters: {closest} m)",
                    spans_text(r),
                    cfg.max_span_ratio
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::pca::PrincipalAxes;
    use nalgebra::{Matrix3, Point3};

    fn cluster(n: usize, spans: [f64; 3]) -> Cluster {
        Cluster {
            indices: (0..n).collect(),
            shape: PrincipalAxes {
                centroid: Point3::origin(),
                axes: Matrix3::identity(),
                variances: Vector3::zeros(),
                spans: Vector3::from(spans),
            },
        }
    }

    #[test]
    fn picks_the_shape_not_the_size() {
        // A bottle 0.30 × 0.10 × 0.10 m; the scan sees its upper half.
        let r = Vector3::new(0.30, 0.10, 0.10);
        let cs = [
            cluster(9000, [0.60, 0.50, 0.05]), // a rock, bigger
            cluster(3000, [0.29, 0.10, 0.05]), // the bottle, half seen
            cluster(2000, [0.28, 0.11, 0.20]), // too deep
            cluster(500, [0.12, 0.10, 0.04]),  // too short
        ];
        let s = select_cluster(&cs, Some(&r), &SelectConfig::default()).unwrap();
        assert_eq!(s.index, 1);
        assert!(s.scores[0].is_none() && s.scores[2].is_none() && s.scores[3].is_none());
        assert_eq!(
            select_cluster(&cs, None, &SelectConfig::default()).unwrap().index,
            0
        );
    }

    #[test]
    fn nothing_fits_is_a_failed_run() {
        let cs = [cluster(100, [1.0, 1.0, 0.1])];
        let err =
            select_cluster(&cs, Some(&Vector3::new(0.3, 0.1, 0.1)), &SelectConfig::default()).unwrap_err();
        assert_eq!(err.exit_code(), 1);
        assert!(err.to_string().contains("no cluster fits"), "{err}");
        assert_eq!(
            select_cluster(&[], None, &SelectConfig::default())
                .unwrap_err()
                .exit_code(),
            1
        );
    }

    #[test]
    fn depth_weight_must_be_finite_and_not_negative() {
        let cs = [cluster(100, [0.3, 0.1, 0.05])];
        for w in [f64::NAN, f64::INFINITY, -1.0] {
            let cfg = SelectConfig {
                depth_weight: w,
                ..SelectConfig::default()
            };
            crate::perception::assert_bad_input(
                select_cluster(&cs, Some(&Vector3::new(0.3, 0.1, 0.1)), &cfg),
                "select.depth_weight",
            );
        }
    }
}
