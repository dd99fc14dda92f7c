//! Vehicle-model and world-step throughput.
use criterion::{Criterion, criterion_group, criterion_main};
fn benches(_c: &mut Criterion) {}
criterion_group!(b, benches);
criterion_main!(b);
