//! The keys a scene-file table takes, read from its serde schema. What a
//! key that does not apply is checked against, and what "did you mean"
//! suggests from, comes from the struct that parses the table, so there is
//! no list of keys to keep beside it.

use serde::de::{self, Deserialize, Deserializer, Visitor};

/// The keys of a struct that derives `Deserialize` (without `flatten`,
/// which hides them): serde hands its field names to the deserializer,
/// and this one keeps them. Empty for anything that is not such a struct.
pub fn keys_of<'de, T: Deserialize<'de>>() -> &'static [&'static str] {
    match T::deserialize(FieldNames) {
        Err(Found(keys)) => keys,
        Ok(_) => &[],
    }
}

/// A deserializer that reads nothing and answers with the field names
/// it is asked for.
struct FieldNames;

/// The field names, carried out as the "error" that ends deserializing.
#[derive(Debug)]
struct Found(&'static [&'static str]);

impl std::fmt::Display for Found {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "keys: {:?}", self.0)
    }
}

impl std::error::Error for Found {}

impl de::Error for Found {
    fn custom<T: std::fmt::Display>(_: T) -> Self {
        Found(&[])
    }
}

impl<'de> Deserializer<'de> for FieldNames {
    type Error = Found;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Found> {
        Err(Found(&[]))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _: &'static str,
        fields: &'static [&'static str],
        _: V,
    ) -> Result<V::Value, Found> {
        Err(Found(fields))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map enum identifier ignored_any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize)]
    #[allow(dead_code)]
    struct Lamp {
        position: [f32; 3],
        #[serde(rename = "type")]
        kind: String,
        scale: Option<f32>,
    }

    #[test]
    fn keys_come_from_the_struct_in_order_with_their_file_names() {
        assert_eq!(keys_of::<Lamp>(), ["position", "type", "scale"]);
        assert!(keys_of::<f32>().is_empty());
    }
}
