//! Items grouped by a dense key (a lane id, a junction id): all items of one key
//! form one slice (compressed rows), built by a stable counting sort, so items
//! keep their input order within a key.

#[derive(Clone, Debug, Default)]
pub struct Buckets<T> {
    starts: Vec<u32>,
    items: Vec<T>,
}

impl<T: Copy> Buckets<T> {
    /// Groups `items` by key (linear, stable).
    pub fn build(key_count: usize, items: &[(u32, T)]) -> Self {
        let mut starts = vec![0u32; key_count + 1];
        for (key, _) in items {
            starts[*key as usize + 1] += 1;
        }
        for i in 0..key_count {
            starts[i + 1] += starts[i];
        }
        let mut fill = starts.clone();
        // Every slot is overwritten below; the copies only give the vector its length.
        let mut out: Vec<T> = items.iter().map(|(_, item)| *item).collect();
        for (key, item) in items {
            let slot = &mut fill[*key as usize];
            out[*slot as usize] = *item;
            *slot += 1;
        }
        Buckets { starts, items: out }
    }

    pub fn get(&self, key: u32) -> &[T] {
        let (a, b) = (self.starts[key as usize], self.starts[key as usize + 1]);
        &self.items[a as usize..b as usize]
    }

    pub fn get_mut(&mut self, key: u32) -> &mut [T] {
        let (a, b) = (self.starts[key as usize], self.starts[key as usize + 1]);
        &mut self.items[a as usize..b as usize]
    }
}
