//! The evaluator's cache: node outputs under (node id, cache key), several keys per node, bounded
//! in bytes with least-recently-used eviction.
//!
//! A node keeps one entry per key it was evaluated under, so the results of other frames (what
//! a node with history reads: `NodeKind::history`) and of a knob's earlier values stay until the
//! budget is exceeded; the latest evaluation's results are never evicted.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::time::Duration;

use super::PortValue;

/// One cached result.
struct Entry {
    outputs: BTreeMap<String, PortValue>,
    /// The time the node took to compute it.
    cost: Duration,
    bytes: usize,
    last_used: u64,
}

/// Node outputs by (node id, key), bounded by a byte budget.
pub(super) struct Cache {
    entries: HashMap<(String, u64), Entry>,
    budget: usize,
    /// The evaluation counter: entries used by the current evaluation carry its value.
    clock: u64,
}

impl Cache {
    /// An empty cache holding at most `budget` bytes past the latest evaluation's results.
    pub(super) fn new(budget: usize) -> Self {
        Self {
            entries: HashMap::new(),
            budget,
            clock: 0,
        }
    }

    /// Set the budget in bytes.
    pub(super) fn set_budget(&mut self, bytes: usize) {
        self.budget = bytes;
    }

    /// Start an evaluation: entries it uses are kept by [`Cache::evict`].
    pub(super) fn tick(&mut self) {
        self.clock += 1;
    }

    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        self.entries.values().map(|e| e.bytes).sum()
    }

    /// Number of distinct nodes with at least one cached result.
    pub(super) fn nodes(&self) -> usize {
        self.entries
            .keys()
            .map(|(id, _)| id)
            .collect::<BTreeSet<_>>()
            .len()
    }

    /// Drop every cached result of node `id`.
    pub(super) fn invalidate(&mut self, id: &str) {
        self.entries.retain(|(node, _), _| node != id);
    }

    /// Drop everything.
    pub(super) fn clear(&mut self) {
        self.entries.clear();
    }

    /// Evaluations started so far (the clock).
    pub(super) fn clock(&self) -> u64 {
        self.clock
    }

    /// Drop every entry no evaluation after the `epoch`-th used.
    pub(super) fn keep_used_since(&mut self, epoch: u64) {
        self.entries.retain(|_, e| e.last_used > epoch);
    }

    /// The cached outputs of `id` under `key`, if they hold every wanted port, and what they
    /// cost to compute.
    pub(super) fn reuse(
        &mut self,
        id: &str,
        key: u64,
        want: &BTreeSet<String>,
    ) -> Option<(BTreeMap<String, PortValue>, Duration)> {
        let e = self
            .entries
            .get_mut(&(id.to_string(), key))
            .filter(|e| want.iter().all(|p| e.outputs.contains_key(p)))?;
        e.last_used = self.clock;
        Some((e.outputs.clone(), e.cost))
    }

    /// Keep a node's fresh outputs under its key, with what they cost.
    pub(super) fn record(
        &mut self,
        id: &str,
        key: u64,
        outputs: &BTreeMap<String, PortValue>,
        cost: Duration,
    ) {
        let bytes = outputs.values().map(PortValue::bytes).sum();
        self.entries.insert(
            (id.to_string(), key),
            Entry {
                outputs: outputs.clone(),
                cost,
                bytes,
                last_used: self.clock,
            },
        );
    }

    /// Evict least-recently-used entries until the budget holds, never one the current
    /// evaluation used.
    pub(super) fn evict(&mut self) {
        let mut held = self.bytes();
        if held <= self.budget {
            return;
        }
        let mut old: Vec<(u64, (String, u64))> = self
            .entries
            .iter()
            .filter(|(_, e)| e.last_used < self.clock)
            .map(|(k, e)| (e.last_used, k.clone()))
            .collect();
        old.sort();
        for (_, k) in old {
            if held <= self.budget {
                break;
            }
            if let Some(e) = self.entries.remove(&k) {
                held -= e.bytes;
            }
        }
    }
}
