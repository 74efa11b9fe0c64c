//! Text renderings shown on the console and embedded in reports.

use crate::identify::{Identifiability, Method};
use nalgebra::Vector3;

/// The identifiability analysis as readable text.
pub fn identifiability_text(
    poses: usize,
    reference: &Vector3<f64>,
    method: Method,
    a: &Identifiability,
) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} poses (reference {:?} mm), {} rows, method {}",
        poses,
        reference.as_slice(),
        3 * (poses - 1),
        method.name()
    );
    let _ = writeln!(
        s,
        "rank {} of {} (relative tolerance {:e})",
        a.rank, a.parameters, a.rank_tolerance
    );
    let _ = writeln!(
        s,
        "condition number {:.4e} (identified subset {:.4e}; columns equilibrated)",
        a.condition_number, a.condition_number_identifiable
    );
    let sv: Vec<String> = a
        .singular_values
        .iter()
        .map(|v| format!("{v:.4e}"))
        .collect();
    let _ = writeln!(s, "singular values: {}", sv.join(" "));
    if a.unidentifiable.is_empty() {
        let _ = writeln!(
            s,
            "unidentifiable: none — all {} errors are identifiable",
            a.parameters
        );
    } else {
        let _ = writeln!(s, "unidentifiable: {}", a.unidentifiable.join(", "));
        for c in &a.unidentifiable_combinations {
            let _ = writeln!(s, "  null direction: {c}");
        }
    }
    let o = &a.observability;
    let _ = writeln!(
        s,
        "observability: O1 {:.4e}  O2 {:.4e}  O3 {:.4e}  O4 {:.4e}  O5 {:.4e}",
        o.o1, o.o2, o.o3, o.o4, o.o5
    );
    s
}
