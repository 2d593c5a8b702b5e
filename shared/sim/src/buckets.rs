//! Items grouped by a dense key (a lane id, a junction id): all items of one key
//! form one slice. Rebuilt every tick, so the cost follows the items, not the
//! keys: only the keys that hold items are touched, and the allocations are
//! kept. Items keep their input order within a key.

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
        let all = || parts.iter().flat_map(|p| p.as_ref().iter());
        if self.ranges.len() == key_count {
            for &key in &self.keys {
                self.ranges[key as usize] = (0, 0);
            }
        } else {
            self.ranges.clear();
            self.ranges.resize(key_count, (0, 0));
        }
        self.keys.clear();
        // Count into `.1`.
        for &(key, _) in all() {
            let range = &mut self.ranges[key as usize];
            if range.1 == 0 {
                self.keys.push(key);
            }
            range.1 += 1;
        }
        // Both ends at the key's start; `.1` is then the scatter cursor.
        let mut start = 0;
        for &key in &self.keys {
            let range = &mut self.ranges[key as usize];
            let count = range.1;
            *range = (start, start);
            start += count;
        }
        self.items.clear();
        self.items.extend(all().map(|(_, item)| *item));
        for &(key, item) in all() {
            let range = &mut self.ranges[key as usize];
            self.items[range.1 as usize] = item;
            range.1 += 1;
        }
    }

    pub fn get(&self, key: u32) -> &[T] {
        let (a, b) = self.ranges[key as usize];
        &self.items[a as usize..b as usize]
    }

    /// Sorts the items of every key holding more than one.
    pub fn sort_each_by(&mut self, mut compare: impl FnMut(&T, &T) -> std::cmp::Ordering) {
        for &key in &self.keys {
            let (a, b) = self.ranges[key as usize];
            if b - a > 1 {
                self.items[a as usize..b as usize].sort_unstable_by(&mut compare);
            }
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
        b.rebuild(2, &[(0, 'z')]);
        assert_eq!(b.get(0), &['z']);
        assert_eq!(b.get(1), &[] as &[char]);
    }
}
