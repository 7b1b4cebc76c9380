//! The limits of what hamel reads: each is a clear error at the place it is exceeded, so that
//! no input exhausts the machine (a 1 MB expression, `x^1000000000`, ten thousand nested
//! parentheses). They are far above what a mechanical model needs: the expanded Whipple
//! bicycle's longest expression is 20 kB, nested 5 deep, with exponents of at most 4.

/// Bytes of one expression's text.
pub const MAX_BYTES: usize = 256 * 1024;

/// Depth of an expression's tree (and of the parser's descent): parentheses, calls, unary
/// minus, powers and chains of divisions each add a level.
pub const MAX_DEPTH: usize = 100;

/// Size of a constant exponent (its numerator and denominator).
pub const MAX_EXPONENT: u32 = 100;

/// Digits of a number literal.
pub const MAX_DIGITS: usize = 100;
