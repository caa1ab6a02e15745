//! Property tests of the DAG's canonical forms: the order in which a sum of products is
//! built does not change the node, and the value is the one of the expression.

use proptest::prelude::*;
use superhelix_codegen::{Graph, Id};

/// A term: integer coefficient and exponents of x, y, z in −3..=3.
type Term = (i64, [i32; 3]);

fn build(g: &mut Graph, terms: &[Term], vars: [Id; 3], reverse: bool) -> Id {
    let mut ids: Vec<Id> = terms
        .iter()
        .map(|(c, e)| {
            let k = g.int(*c);
            let mut f = vec![k];
            let order: Vec<usize> = if reverse {
                vec![2, 1, 0]
            } else {
                vec![0, 1, 2]
            };
            for i in order {
                f.push(g.pow(vars[i], e[i]));
            }
            if reverse {
                f.reverse();
            }
            g.mul(&f)
        })
        .collect();
    if reverse {
        ids.reverse();
        // and nest the sum differently
        let mut acc = g.zero();
        for t in ids {
            acc = g.add2(t, acc);
        }
        acc
    } else {
        g.add(&ids)
    }
}

proptest! {
    #[test]
    fn build_order_does_not_matter(terms in prop::collection::vec((-5i64..=5, [-3i32..=3, -3i32..=3, -3i32..=3]), 0..12)) {
        let mut g = Graph::new();
        let v = [g.symbol("x"), g.symbol("y"), g.symbol("z")];
        let a = build(&mut g, &terms, v, false);
        let b = build(&mut g, &terms, v, true);
        prop_assert_eq!(a, b);
        let (x, y, z) = (1.3, -0.7, 2.1);
        let direct: f64 = terms
            .iter()
            .map(|(c, e)| *c as f64 * f64::powi(x, e[0]) * f64::powi(y, e[1]) * f64::powi(z, e[2]))
            .sum();
        let got = g.eval(a, &[(v[0], x), (v[1], y), (v[2], z)]);
        let size: f64 = terms
            .iter()
            .map(|(c, e)| (*c as f64 * f64::powi(x, e[0]) * f64::powi(y, e[1]) * f64::powi(z, e[2])).abs())
            .sum();
        prop_assert!((got - direct).abs() <= 1e-13 * size.max(1.0));
    }
}
