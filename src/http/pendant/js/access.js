// Who may do what, as the page greys it out: the least role of each action, mirroring
// `Action::role` in src/app/access.rs (the service decides; a control the caller's role may
// not use is off so nobody meets a 403 by pressing it). A control in index.html names its
// action with `data-needs`, and `data-scope="service"` when it concerns the whole service
// rather than one cell (creating a cell), which a token limited to some cells may not do.

/** The roles, each allowed all that the one before it is. */
export const ROLES = ['operator', 'engineer', 'admin'];

/** The least role of each action (src/app/access.rs, `Action::role`). */
export const LEAST_ROLE = {
  read: 'operator', // cells, stats, programs, routines, frames, reach, who am I
  teach: 'operator', // record, accept, adjust, reject, undo, finish, start a routine, look ahead
  edit: 'engineer', // create cells and programs, edit waypoints, calibrate
  delete: 'admin', // delete cells and programs
  administer: 'admin', // tokens, backups
};

const rank = (role) => ROLES.indexOf(role);

/**
 * Whether the caller (`GET /v1/whoami`'s answer; null while unknown: reading only) may do
 * `action`, on the whole service when `scope` is `'service'`.
 */
export function allowed(me, action, scope) {
  const least = LEAST_ROLE[action];
  if (least === undefined) throw new Error(`no such action: ${action}`);
  if (!me) return action === 'read';
  if (rank(me.role) < rank(least)) return false;
  return scope !== 'service' || action === 'read' || me.cells == null;
}

/** Why the caller may not do `action` (for a control's title); null when it may. */
export function refusal(me, action, scope) {
  if (allowed(me, action, scope)) return null;
  if (!me) return 'not signed in yet';
  const least = LEAST_ROLE[action];
  if (rank(me.role) < rank(least)) return `needs the ${least} role (you are ${me.role})`;
  return 'needs a token not limited to some cells';
}

/** The caller as the header shows it: `name (role) · cells 3, 5`. */
export function describe(me) {
  if (!me.authenticated) return `${me.name} (${me.role}): no token needed`;
  const cells = me.cells == null ? '' : ` · cell${me.cells.length === 1 ? '' : 's'} ${me.cells.join(', ')}`;
  return `${me.name} (${me.role})${cells}`;
}
