//! Items grouped by a dense key (a lane id, a junction id): all items of one key
//! form one slice. Rebuilt every tick, so the cost follows the items, not the
//! keys: only the keys that held or hold items are touched (unless they are
//! many: then one sweep resets them), and the allocations are kept. Items keep
//! their input order within a key.

/// Keys in use above one in this many of all keys: the ranges are reset by
/// one sweep rather than key by key.
const DENSE_KEYS: usize = 32;

#[derive(Clone, Debug)]
pub struct Buckets<T> {
    /// Per key: start and end in `items`; (0, 0) for a key without items.
    ranges: Vec<(u32, u32)>,
    /// The keys holding items, in order of first appearance.
    keys: Vec<u32>,
    items: Vec<T>,
}

impl<T> Default for Buckets<T> {
    fn default() -> Self {
        Buckets {
            ranges: Vec::new(),
            keys: Vec::new(),
            items: Vec::new(),
        }
    }
}

impl<T: Copy> Buckets<T> {
    /// Groups `items` by key.
    pub fn build(key_count: usize, items: &[(u32, T)]) -> Self {
        let mut buckets = Buckets::default();
        buckets.rebuild(key_count, items);
        buckets
    }

    /// Regroups in place (a stable counting sort over the keys in use).
    pub fn rebuild(&mut self, key_count: usize, items: &[(u32, T)]) {
        self.rebuild_from_parts(key_count, &[items]);
    }

    /// Regroups in place the items of `parts` taken one after the other.
    pub fn rebuild_from_parts<P: AsRef<[(u32, T)]>>(&mut self, key_count: usize, parts: &[P]) {
        if self.ranges.len() == key_count && self.keys.len() < key_count / DENSE_KEYS {
            // Few keys were in use: reset theirs, a random line each.
            for &key in &self.keys {
                self.ranges[key as usize] = (0, 0);
            }
        } else {
            // Many were (or the key count changed): one sequential sweep
            // costs less than that many random lines (1% of a 10k-vehicle tick).
            self.ranges.clear();
            self.ranges.resize(key_count, (0, 0));
        }
        self.keys.clear();
        // Count into `.1`. (Loops over the parts rather than a flat_map: this
        // runs for every item every tick, and the nested loops compile tighter.)
        for part in parts {
            for &(key, _) in part.as_ref() {
                let range = &mut self.ranges[key as usize];
                if range.1 == 0 {
                    self.keys.push(key);
                }
                range.1 += 1;
            }
        }
        // Both ends at the key's start; `.1` is then the scatter cursor.
        let mut start = 0;
        for &key in &self.keys {
            let range = &mut self.ranges[key as usize];
            let count = range.1;
            *range = (start, start);
            start += count;
        }
        // Sized with any item (each slot is overwritten below): cheaper than
        // copying the items in only to scatter them again.
        self.items.clear();
        if let Some(&(_, any)) = parts.iter().find_map(|p| p.as_ref().first()) {
            self.items.resize(start as usize, any);
        }
        for part in parts {
            for &(key, item) in part.as_ref() {
                let range = &mut self.ranges[key as usize];
                self.items[range.1 as usize] = item;
                range.1 += 1;
            }
        }
    }

    /// Asks for the cache line of the key's range (see [`crate::prefetch`]).
    pub fn prefetch_key(&self, key: u32) {
        if let Some(range) = self.ranges.get(key as usize) {
            crate::prefetch::line(range);
        }
    }

    pub fn get(&self, key: u32) -> &[T] {
        let (a, b) = self.ranges[key as usize];
        &self.items[a as usize..b as usize]
    }

    /// Sorts the items of every key holding more than one.
    pub fn sort_each_by(&mut self, compare: impl Fn(&T, &T) -> std::cmp::Ordering) {
        sort_keys(&self.ranges, &self.keys, &mut self.items, 0, &compare);
    }
}

impl<T: Copy + Send> Buckets<T> {
    /// [`Buckets::sort_each_by`] on two threads: the keys' items lie in the
    /// order of the keys, so the two halves of the keys own disjoint halves of
    /// the items.
    pub fn par_sort_each_by(&mut self, compare: impl Fn(&T, &T) -> std::cmp::Ordering + Sync) {
        let (low_keys, high_keys) = self.keys.split_at(self.keys.len() / 2);
        let split = high_keys
            .first()
            .map_or(self.items.len(), |&k| self.ranges[k as usize].0 as usize);
        let (low, high) = self.items.split_at_mut(split);
        let ranges = &self.ranges;
        rayon::join(
            || sort_keys(ranges, low_keys, low, 0, &compare),
            || sort_keys(ranges, high_keys, high, split, &compare),
        );
    }
}

/// Sorts the items of `keys` within `items`, whose first element is item `first`.
fn sort_keys<T>(
    ranges: &[(u32, u32)],
    keys: &[u32],
    items: &mut [T],
    first: usize,
    compare: &impl Fn(&T, &T) -> std::cmp::Ordering,
) {
    for &key in keys {
        let (a, b) = ranges[key as usize];
        if b - a > 1 {
            items[a as usize - first..b as usize - first].sort_unstable_by(compare);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_by_key_stably_and_rebuilds_in_place() {
        let mut b = Buckets::build(4, &[(2, 'a'), (0, 'b'), (2, 'c'), (3, 'd')]);
        assert_eq!(b.get(0), &['b']);
        assert_eq!(b.get(1), &[] as &[char]);
        assert_eq!(b.get(2), &['a', 'c']);
        assert_eq!(b.get(3), &['d']);
        b.rebuild(4, &[(1, 'x'), (1, 'y')]);
        for empty in [0, 2, 3] {
            assert_eq!(b.get(empty), &[] as &[char], "key {empty}");
        }
        assert_eq!(b.get(1), &['x', 'y']);
        b.sort_each_by(|a, b| b.cmp(a));
        assert_eq!(b.get(1), &['y', 'x']);
        b.rebuild(
            3,
            &[(2, 'p'), (0, 'c'), (2, 'q'), (0, 'a'), (1, 'z'), (0, 'b')],
        );
        b.par_sort_each_by(|a, b| a.cmp(b));
        assert_eq!(b.get(0), &['a', 'b', 'c']);
        assert_eq!(b.get(1), &['z']);
        assert_eq!(b.get(2), &['p', 'q']);
        b.rebuild(2, &[(0, 'z')]);
        assert_eq!(b.get(0), &['z']);
        assert_eq!(b.get(1), &[] as &[char]);
    }

    #[test]
    fn keys_in_use_are_reset_one_by_one_when_few_and_in_one_sweep_when_many() {
        let keys = 100 * DENSE_KEYS as u32;
        let mut b = Buckets::build(keys as usize, &[(7, 1), (keys - 1, 2)]);
        // Few keys in use before: each reset on its own.
        b.rebuild(keys as usize, &[(8, 3)]);
        assert_eq!(b.get(7), &[] as &[i32]);
        assert_eq!(b.get(keys - 1), &[] as &[i32]);
        assert_eq!(b.get(8), &[3]);
        // Many: one sweep.
        let many: Vec<(u32, i32)> = (0..keys / 2).map(|k| (k * 2, k as i32)).collect();
        b.rebuild(keys as usize, &many);
        b.rebuild(keys as usize, &[(1, 9)]);
        assert!((0..keys).filter(|&k| k != 1).all(|k| b.get(k).is_empty()));
        assert_eq!(b.get(1), &[9]);
    }
}
