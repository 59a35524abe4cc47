//! [`Token`]: a record's key. nuScenes' tokens are 32 lowercase hexadecimal digits, held as
//! one `u128` (16 bytes instead of a 32-byte string and its allocation: the annotations of a
//! large version number over a million); a dataset in the format may use any other string,
//! held as it is. Either way the token prints as it was written.

use std::fmt;

/// A record's token.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Token {
    /// 32 lowercase hexadecimal digits.
    Hex(u128),
    /// Any other string.
    Text(Box<str>),
}

impl Token {
    /// The token written `s`.
    pub fn new(s: &str) -> Self {
        let hex = s.len() == 32
            && s.bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
        match hex.then(|| u128::from_str_radix(s, 16).ok()).flatten() {
            Some(n) => Token::Hex(n),
            None => Token::Text(s.into()),
        }
    }

    /// A 64-bit number of the token (its first 16 hex digits, or a hash of another string),
    /// for outputs that number instances.
    pub fn number(&self) -> u64 {
        match self {
            Token::Hex(n) => (n >> 64) as u64,
            Token::Text(s) => {
                let h = blake3::hash(s.as_bytes());
                u64::from_le_bytes(h.as_bytes()[..8].try_into().expect("8 bytes"))
            }
        }
    }
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Token::Hex(n) => write!(f, "{n:032x}"),
            Token::Text(s) => f.write_str(s),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_print_as_written() {
        for s in [
            "0a0d6b8c2e884134a3b48df43d54c36a",
            "000000000000000000000000000000ff",
            "Scene_1",
            "0A0D6B8C2E884134A3B48DF43D54C36A",
            "abc",
        ] {
            assert_eq!(Token::new(s).to_string(), s);
        }
        assert!(matches!(
            Token::new("0a0d6b8c2e884134a3b48df43d54c36a"),
            Token::Hex(_)
        ));
        assert!(matches!(
            Token::new("0A0D6B8C2E884134A3B48DF43D54C36A"),
            Token::Text(_)
        ));
        assert_eq!(
            Token::new("0a0d6b8c2e884134a3b48df43d54c36a").number(),
            0x0a0d6b8c2e884134
        );
        assert_ne!(Token::new("a").number(), Token::new("b").number());
    }
}
