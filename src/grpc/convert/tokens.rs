//! Tokens: a token asked for, a token (without its secret), one just created (with it), and
//! who a call's token says the caller is.

use crate::api::{CreatedToken, NewToken, Role, Token, WhoAmI};

use super::wire::{both_ways, enum_both_ways};

enum_both_ways!(Role => Role as "role" { Operator, Engineer, Admin });

both_ways!(NewToken => CreateTokenRequest { name, role, cells });
both_ways!(Token => Token { name, role, cells, created_at });
both_ways!(CreatedToken => CreatedToken { token, secret });
both_ways!(WhoAmI => Caller { name, role, cells, authenticated });
