//! Fixed-length arrays read exactly: the toml crate fills `[f32; 3]` from
//! the first numbers of a longer array without a word, so `resolution =
//! [16, 16, 16]` would pass for [16, 16].

use serde::de::{Deserialize, Deserializer, Error, SeqAccess, Visitor};

fn sized<E: Error, T, const N: usize>(v: Vec<T>) -> Result<[T; N], E> {
    let n = v.len();
    v.try_into()
        .map_err(|_| E::invalid_length(n, &format!("an array of {N} numbers").as_str()))
}

/// An array of N values; anything else (`"512x512"`) is refused with
/// the form expected (`[a, b]`).
struct Array<T, const N: usize>(Vec<T>);

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Array<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_seq(ArrayVisitor::<T, N>(std::marker::PhantomData))
    }
}

struct ArrayVisitor<T, const N: usize>(std::marker::PhantomData<T>);

impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for ArrayVisitor<T, N> {
    type Value = Array<T, N>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let names = ["a", "b", "c", "d"];
        let form: Vec<&str> = names.iter().copied().cycle().take(N).collect();
        write!(f, "an array of {N} numbers, written [{}]", form.join(", "))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut v = Vec::with_capacity(N.min(16));
        while let Some(x) = seq.next_element()? {
            v.push(x);
        }
        Ok(Array(v))
    }
}

pub fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    sized(Array::<T, N>::deserialize(d)?.0)
}

pub fn option<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<Array<T, N>>::deserialize(d)?
        .map(|a| sized(a.0))
        .transpose()
}

/// A quad's four corners of three coordinates.
pub fn quad<'de, D>(d: D) -> Result<[[f32; 3]; 4], D::Error>
where
    D: Deserializer<'de>,
{
    let corners = Vec::<Vec<f32>>::deserialize(d)?
        .into_iter()
        .map(sized::<D::Error, f32, 3>)
        .collect::<Result<Vec<_>, _>>()?;
    let n = corners.len();
    corners
        .try_into()
        .map_err(|_| D::Error::invalid_length(n, &"four corners"))
}
