// SPDX-License-Identifier: Apache-2.0
// mgc-display's page: draws what the server pushes (Server-Sent Events on /api/events) and posts
// the operator's commands. Nothing here holds the key; the server signs.
'use strict';

const SUPERVISOR = ['UNKNOWN', 'INIT', 'HOLD', 'PLANNING', 'EXECUTING', 'STOPPING', 'REPLANNING', 'FAULT', 'ESTOP'];
const SEVERITY = ['unknown', 'info', 'warn', 'slow-down', 'stop', 'fault'];
const SOURCE = ['unknown', 'collision', 'envelope', 'load chart', 'sensing', 'watchdog', 'planner', 'operator'];
const UNIT = ['', '', ' m', ' rad', ' %', ' s', ' m/s', ' rad/s'];
const INSTRUCTION = ['unknown', 'hold', 'move joint', 'wait for re-plan', 'stopped', 'done'];
const ALERT_UNIT_SECOND = 5;
const SOURCE_COLLISION = 1;
const LOAD_GAUGE_MAX_PCT = 120;
// How a tracked obstacle is drawn, by the server's status (docs/operator-display.md): a moving one
// filled magenta, a still one filled blue, one whose pose is not current dashed and unfilled.
const OBSTACLE_STYLE = {
  'moving': { fill: 'rgba(190,40,190,0.55)', stroke: '#601060', dashed: false },
  'still': { fill: 'rgba(40,90,170,0.45)', stroke: '#1d3d66', dashed: false },
  'pose unknown': { fill: null, stroke: '#c00', dashed: true },
  'not current': { fill: null, stroke: '#c00', dashed: true },
};
const OBSTACLE_STALE_STYLE = { fill: null, stroke: '#999', dashed: true };

const $ = (id) => document.getElementById(id);
let config = null;
let scene = null;
let plan = null;
let last = null;            // the latest pushed message
let lastMessageMs = -1;     // performance.now() when it came
let stale = true;

// ---- numbers and words ----

function fmt(v, digits) {
  return (v === null || v === undefined || !Number.isFinite(v)) ? '—' : v.toFixed(digits);
}
function jointUnit(j) {
  return scene && scene.joints[j] ? scene.joints[j].unit : 'rad';
}
function jointName(j) {
  return scene && scene.joints[j] ? scene.joints[j].name : 'joint ' + j;
}
// A joint value for the operator: degrees for revolute joints, metres for prismatic ones.
function jointValue(j, v) {
  if (v === null || !Number.isFinite(v)) return '—';
  return jointUnit(j) === 'rad' ? (v * 180 / Math.PI).toFixed(1) + ' deg' : v.toFixed(2) + ' m';
}
function setText(id, text) {
  const el = $(id);
  if (el.textContent !== text) el.textContent = text;
}

// ---- drawing ----

function hull(points) {
  const p = points.slice().sort((a, b) => a[0] - b[0] || a[1] - b[1]);
  if (p.length < 3) return p;
  const cross = (o, a, b) => (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
  const lower = [];
  for (const q of p) {
    while (lower.length >= 2 && cross(lower[lower.length - 2], lower[lower.length - 1], q) <= 0) lower.pop();
    lower.push(q);
  }
  const upper = [];
  for (let i = p.length - 1; i >= 0; i--) {
    const q = p[i];
    while (upper.length >= 2 && cross(upper[upper.length - 2], upper[upper.length - 1], q) <= 0) upper.pop();
    upper.push(q);
  }
  upper.pop();
  lower.pop();
  return lower.concat(upper);
}

// One view: world axes ax (right) and ay (up) at one scale in px/m, fitted to the scene's bounds.
function makeView(canvas, ax, ay) {
  const lo = scene.bounds_lo, hi = scene.bounds_hi;
  const margin = 30;
  const spanX = Math.max(hi[ax] - lo[ax], 1), spanY = Math.max(hi[ay] - lo[ay], 1);
  const scale = Math.min((canvas.width - 2 * margin) / spanX, (canvas.height - 2 * margin - 20) / spanY);
  const ox = margin + ((canvas.width - 2 * margin) - spanX * scale) / 2;
  const oy = canvas.height - margin - 20 - ((canvas.height - 2 * margin - 20) - spanY * scale) / 2;
  return {
    canvas, ctx: canvas.getContext('2d'), scale, ax, ay,
    map: (p) => [ox + (p[ax] - lo[ax]) * scale, oy - (p[ay] - lo[ay]) * scale],
  };
}

function drawShape(view, corners, fill, stroke, dashed) {
  const pts = hull(corners.map(view.map));
  if (pts.length < 2) return;
  const c = view.ctx;
  c.beginPath();
  c.moveTo(pts[0][0], pts[0][1]);
  for (const q of pts.slice(1)) c.lineTo(q[0], q[1]);
  c.closePath();
  c.setLineDash(dashed ? [5, 4] : []);
  if (fill) { c.fillStyle = fill; c.fill(); }
  c.strokeStyle = stroke;
  c.lineWidth = 1;
  c.stroke();
  c.setLineDash([]);
}

function drawPolyline(view, points, style, width) {
  if (points.length < 2) return;
  const c = view.ctx;
  c.beginPath();
  const first = view.map(points[0]);
  c.moveTo(first[0], first[1]);
  for (const p of points.slice(1)) {
    const q = view.map(p);
    c.lineTo(q[0], q[1]);
  }
  c.strokeStyle = style;
  c.lineWidth = width;
  c.stroke();
}

// A bar of a round length (1, 2 or 5 times a power of ten) about a fifth of the view wide.
function drawScaleBar(view) {
  const c = view.ctx;
  const target = view.canvas.width / 5 / view.scale;
  const pow = Math.pow(10, Math.floor(Math.log10(target)));
  const len = [1, 2, 5, 10].map((k) => k * pow).filter((l) => l <= target * 1.5).pop() || pow;
  const x0 = 12, y0 = view.canvas.height - 12, px = len * view.scale;
  c.strokeStyle = '#111';
  c.lineWidth = 2;
  c.beginPath();
  c.moveTo(x0, y0 - 5); c.lineTo(x0, y0); c.lineTo(x0 + px, y0); c.lineTo(x0 + px, y0 - 5);
  c.stroke();
  c.fillStyle = '#111';
  c.font = '12px sans-serif';
  c.fillText(len + ' m', x0 + px + 6, y0);
  view.canvas.dataset.scaleBarM = String(len);
}

// The site does not move: its obstacles are drawn once into a layer that each frame copies.
function staticLayer(view) {
  const layer = document.createElement('canvas');
  layer.width = view.canvas.width;
  layer.height = view.canvas.height;
  const v = Object.assign({}, view, { canvas: layer, ctx: layer.getContext('2d') });
  // Ground line in the side view.
  if (view.ay === 2) drawPolyline(v, [[scene.bounds_lo[0] - 1e3, 0, 0], [scene.bounds_hi[0] + 1e3, 0, 0]], '#8a6', 1);
  for (const o of scene.obstacles) drawShape(v, o.corners, 'rgba(90,90,90,0.45)', '#333', false);
  drawScaleBar(v);
  view.canvas.dataset.scaleBarM = layer.dataset.scaleBarM;
  return layer;
}

function drawView(view) {
  const c = view.ctx;
  c.clearRect(0, 0, view.canvas.width, view.canvas.height);
  c.drawImage(view.layer, 0, 0);
  if (plan && plan.tool_path.length > 1) {
    const seg = last && last.guidance && !stale ? last.guidance.segment_index : -1;
    drawPolyline(view, plan.tool_path, '#1f5fbf', 2);
    // The waypoints passed so far in green: the plan's progress.
    if (seg > 0 && plan.waypoint_tools.length > 1) drawPolyline(view, plan.waypoint_tools.slice(0, seg + 1), '#1a9a3a', 4);
    for (const p of plan.waypoint_tools) {
      const q = view.map(p);
      c.fillStyle = '#1f5fbf';
      c.fillRect(q[0] - 2, q[1] - 2, 4, 4);
    }
  }
  drawObstacles(view);
  drawSite(view);
  const machine = last && last.state && last.state.machine;
  if (machine) {
    for (const body of machine.bodies) {
      drawShape(view, body, stale ? 'rgba(160,160,160,0.35)' : 'rgba(240,150,20,0.75)', stale ? '#999' : '#7a4a00', stale);
    }
    const t = view.map(machine.tool);
    c.fillStyle = stale ? '#999' : '#c00';
    c.beginPath();
    c.arc(t[0], t[1], 4, 0, 2 * Math.PI);
    c.fill();
    if (stale) {
      c.fillStyle = '#c00';
      c.font = 'bold 13px sans-serif';
      c.fillText('machine as last reported (not current)', 12, 18);
    }
  }
}

// Each tracked obstacle's parts at its pose, with its name and what the pose is worth.
function drawObstacles(view) {
  const list = last && last.obstacles ? last.obstacles.list : [];
  const c = view.ctx;
  for (const o of list) {
    if (!o.parts.length) continue;
    const style = stale ? OBSTACLE_STALE_STYLE : OBSTACLE_STYLE[o.status] || OBSTACLE_STALE_STYLE;
    for (const part of o.parts) drawShape(view, part, style.fill, style.stroke, style.dashed);
    if (view.ay !== 1 || !o.position) continue;
    const q = view.map(o.position);
    c.fillStyle = style.stroke;
    c.beginPath();
    c.arc(q[0], q[1], 3, 0, 2 * Math.PI);
    c.fill();
    c.font = 'bold 12px sans-serif';
    c.fillText((o.name || 'obstacle ' + o.index) + ': ' + obstacleWords(o), q[0] + 6, q[1] - 6);
  }
}

// The obstacle's state in words; while the feed is stale nothing is current.
function obstacleWords(o) {
  if (stale) return 'as last reported (not current)';
  if (o.status === 'moving') {
    return 'moving' + (Number.isFinite(o.speed_m_s) ? ' ' + o.speed_m_s.toFixed(1) + ' m/s' : '') +
      (Number.isFinite(o.yaw_rate_rad_s) ? ', turning ' + (o.yaw_rate_rad_s * 180 / Math.PI).toFixed(1) + ' deg/s' : '');
  }
  if (o.status === 'still') return 'still';
  if (o.status === 'pose unknown') return 'pose unknown' + (Number.isFinite(o.fix_age_s) ? ', last fix ' + o.fix_age_s.toFixed(1) + ' s ago' : '');
  if (o.status === 'not current') return 'pose unknown, no obstacle poses for ' + last.obstacles.age_s.toFixed(1) + ' s';
  return 'never located';
}

function renderObstacles(m) {
  const el = $('tracked-obstacles');
  const o = m.obstacles;
  const items = o ? o.list.map((b) => {
    const cls = stale ? 'stale' : b.status === 'moving' ? 'moving' : b.status === 'still' ? 'still' : 'unknown';
    let at = '';
    if (b.position) {
      at = ' at (' + b.position[0].toFixed(1) + ', ' + b.position[1].toFixed(1) + ') m';
      if (!stale && Number.isFinite(b.sigma_m) && (b.status === 'moving' || b.status === 'still')) at += ' ± ' + b.sigma_m.toFixed(2) + ' m';
    }
    let px = '';
    if (planView && b.position) {
      const q = planView.map(b.position);
      px = '" data-plan-px="' + q[0].toFixed(1) + ',' + q[1].toFixed(1);
    }
    return '<li class="' + cls + '" data-obstacle-index="' + b.index + '" data-status="' + (stale ? 'stale' : b.status) + px + '">' +
      (b.name || 'obstacle ' + b.index) + ': ' + obstacleWords(b) + at + '</li>';
  }) : [];
  if (o && o.num_tracked > o.list.length) items.push('<li class="unknown">' + (o.num_tracked - o.list.length) + ' more tracked, not on the feed</li>');
  const html = items.length ? items.join('') : '<li class="none">none on the feed</li>';
  if (el.innerHTML !== html) el.innerHTML = html;
}

// The other machines of the site at their reported joints, teal; dashed grey when not current.
function drawSite(view) {
  const members = last && last.site ? last.site.members : [];
  const c = view.ctx;
  for (const m of members) {
    if (m.own || !m.bodies) continue;
    const old = stale || !m.current;
    for (const body of m.bodies) drawShape(view, body, old ? null : 'rgba(20,150,140,0.55)', old ? '#999' : '#0a4d48', old);
    if (view.ay !== 1) continue;
    const q = view.map(m.base);
    c.fillStyle = old ? '#999' : '#0a4d48';
    c.font = 'bold 12px sans-serif';
    c.fillText('machine ' + m.id + (old ? ' (as last reported, not current)' : last.site.verified ? '' : ' (unverified)'), q[0] + 6, q[1] + 14);
  }
}

function renderSite(m) {
  const s = m.site;
  if (!s) return;
  $('site-box').hidden = false;
  setText('site-note', s.name + ': ' + (s.verified ? 'states verified with the site key' :
    'UNVERIFIED: no site key, any program on the network could send these states') +
    (Object.keys(s.refused).length ? '; refused ' + Object.entries(s.refused).map(([r, n]) => r + ' ' + n).join(', ') : ''));
  const html = s.members.filter((b) => !b.own).map((b) => {
    const heard = b.age_s !== null;
    const cls = stale ? 'stale' : !heard ? 'none' : b.current ? 'current' : 'old';
    let what = !heard ? 'not heard from' : stale || !b.current ? 'as last reported (not current), ' + b.age_s.toFixed(1) + ' s ago'
      : (SUPERVISOR[b.supervisor] || 'UNKNOWN');
    return '<li class="' + cls + '" data-machine-id="' + b.id + '" data-status="' + cls + '">machine ' + b.id + ' (' + b.name +
      ', priority ' + b.priority + '): ' + what + '</li>';
  }).join('');
  if ($('site-members').innerHTML !== html) $('site-members').innerHTML = html;
}

let planView = null, sideView = null;
let drawPending = false;
function draw() {
  if (!scene || drawPending) return;
  drawPending = true;
  requestAnimationFrame(() => {
    drawPending = false;
    drawNow();
  });
}
// Grows the views' bounds (and redraws the site) when the machine or the plan reaches outside them,
// so that the scale stays true and nothing is cut off.
function fitBounds(points) {
  const lo = scene.bounds_lo, hi = scene.bounds_hi;
  let grown = false;
  for (const p of points) {
    for (let a = 0; a < 3; a++) {
      if (p[a] < lo[a]) { lo[a] = p[a] - 0.1 * (hi[a] - p[a]); grown = true; }
      if (p[a] > hi[a]) { hi[a] = p[a] + 0.1 * (p[a] - lo[a]); grown = true; }
    }
  }
  if (grown) planView = sideView = null;
}

// The views fitted to what the latest message brings, built anew when they grew. The readouts call
// it too, before they map a position into the plan view (the obstacle list's data-plan-px), so
// that the list and the drawing use the same scale from the message that grew the views on.
function fitViews() {
  if (!scene) return;
  const machine = last && last.state && last.state.machine;
  if (machine) fitBounds([].concat(...machine.bodies));
  if (plan) fitBounds(plan.tool_path);
  if (last && last.obstacles) for (const o of last.obstacles.list) for (const part of o.parts) fitBounds(part);
  if (last && last.site) for (const m of last.site.members) if (m.bodies && !m.own) for (const b of m.bodies) fitBounds(b);
  if (!planView) {
    planView = makeView($('plan-view'), 0, 1);
    sideView = makeView($('side-view'), 0, 2);
    planView.layer = staticLayer(planView);
    sideView.layer = staticLayer(sideView);
  }
}

function drawNow() {
  fitViews();
  drawView(planView);
  drawView(sideView);
}

// ---- the readouts ----

function renderStale(ageS, why) {
  document.body.classList.add('stale');
  setText('feed-status', 'FEED STALE');
  $('feed-status').className = 'badge bad';
  setText('stale-banner', 'FEED STALE: ' + why + (ageS === null ? '' : ' (last machine state ' + ageS.toFixed(1) + ' s ago)') +
    '. Nothing below is current.');
  for (const el of document.querySelectorAll('.live')) el.textContent = '—';
  setText('supervisor', '—');
  $('supervisor').className = 'badge';
  setText('approach-countdown', '—');
  $('load-bar').style.width = '0';
  $('joints').tBodies[0].textContent = '';
}

function render() {
  const m = last;
  if (!m) return;
  const f = m.feed;
  setText('feed-counters', 'received ' + Object.values(f.received).reduce((a, b) => a + b, 0) + ' messages, malformed ' +
    Object.entries(f.malformed).map(([c, n]) => c + ' ' + n).join(', ').replace(/^$/, '0'));
  $('feed-counters').className = Object.keys(f.malformed).length ? 'warn' : '';
  renderAlerts(m);
  renderStatuses(m);
  if (m.playback) renderPlayback(m.playback);
  fitViews();
  renderObstacles(m);
  renderSite(m);
  if (stale) {
    draw();
    return;
  }
  document.body.classList.remove('stale');
  const s = m.state;
  setText('feed-status', config.playback ? 'PLAYBACK' : 'LIVE');
  $('feed-status').className = 'badge good';
  $('feed-status').dataset.utime = String(s.utime);
  const sup = SUPERVISOR[s.supervisor] || 'UNKNOWN';
  setText('supervisor', sup);
  $('supervisor').className = 'badge sup-' + sup.toLowerCase();

  const load = s.load_moment_pct;
  setText('load-value', fmt(load, 0) + ' %');
  const bar = $('load-bar');
  bar.style.width = Number.isFinite(load) ? Math.min(100, Math.max(0, load / LOAD_GAUGE_MAX_PCT * 100)) + '%' : '0';
  bar.className = load >= 100 ? 'over' : load >= 90 ? 'near' : '';

  const tbody = $('joints').tBodies[0];
  const rows = s.joints.map((q, j) => '<tr><td>' + jointName(j) + '</td><td>' + jointValue(j, q) + '</td><td>' +
    jointValue(j, s.velocities[j]).replace(/( deg| m)$/, '$1/s') + '</td><td>' + (s.faults[j] ? 'fault ' + s.faults[j] : 'ok') + '</td></tr>');
  const html = rows.join('');
  if (tbody.innerHTML !== html) tbody.innerHTML = html;

  const g = m.guidance;
  if (g) {
    const mj = g.moving_joint;
    setText('move-joint', mj >= 0 ? jointName(mj) : (INSTRUCTION[g.instruction] || '—'));
    setText('move-target', mj >= 0 ? jointValue(mj, g.target_position) : '—');
    setText('move-remaining', mj >= 0 ? jointValue(mj, g.joint_distance_remaining) : '—');
    setText('plan-progress', g.num_segments > 0 ? 'segment ' + (g.segment_index + 1) + ' of ' + g.num_segments : 'no plan');
    setText('time-remaining', fmt(g.time_remaining_s, 1) + ' s');
    setText('speed-scale', fmt(g.speed_scale * 100, 0) + ' %');
  }
  const i = m.instruction;
  if (i) {
    setText('instruction-text', i.text || INSTRUCTION[g ? g.instruction : 0] || '—');
    setText('obstacle-distance', Number.isFinite(i.obstacle_clearance_m) ? i.obstacle_clearance_m.toFixed(1) + ' m' +
      (i.obstacle_index >= 0 ? ' (obstacle ' + i.obstacle_index + ')' : '') : 'none in range');
    setText('limit-margin', i.limit_joint >= 0 ? jointName(i.limit_joint) + ' ' + jointValue(i.limit_joint, i.limit_margin) : '—');
  }
  // The approach warning: a collision alert whose value is the time until the obstacle is
  // predicted within the stop margin, counted down since it came.
  const approach = m.alerts.filter((a) => a.active && a.source === SOURCE_COLLISION && a.unit === ALERT_UNIT_SECOND);
  if (approach.length) {
    const a = approach.reduce((x, y) => (x.value - x.last_ago_s <= y.value - y.last_ago_s ? x : y));
    setText('approach-countdown', Math.max(0, a.value - a.last_ago_s).toFixed(1) + ' s (obstacle ' + a.index + ')');
    $('approach-countdown').className = 'live warn';
  } else {
    setText('approach-countdown', 'none');
    $('approach-countdown').className = 'live';
  }
  const t = m.timing;
  setText('loop-health', t ? 'loop ' + (t.period_us / 1000).toFixed(0) + ' ms: ' + t.deadline_misses + ' deadline misses, ' +
    t.watchdog_trips + ' watchdog trips, compute p99 ' + t.compute_p99_us + ' µs (max ' + t.compute_max_us + '), lateness p99 ' +
    t.lateness_p99_us + ' µs, snapshots dropped ' + t.snapshots_dropped : 'no loop timing yet');
  $('loop-health').className = 'live' + (t && (t.deadline_misses > 0 || t.watchdog_trips > 0) ? ' warn' : '');
  const h = m.health;
  setText('bus-health', h ? 'bus: ' + h.bus_frames_decoded + ' frames, ' + h.bus_malformed + ' malformed, ' + h.bus_unknown_frames +
    ' unknown; commands ' + h.commands_accepted + ' accepted, ' + h.commands_refused + ' refused' : 'no health counters yet');
  draw();
}

function renderAlerts(m) {
  const list = $('alerts');
  const items = m.alerts.slice().sort((a, b) => (b.active - a.active) || (b.severity - a.severity) || (a.raised_ago_s - b.raised_ago_s));
  const html = items.length ? items.map((a) => {
    let what = (SEVERITY[a.severity] || 'unknown') + ' ' + (SOURCE[a.source] || 'unknown');
    if (a.index >= 0) what += ' #' + a.index;
    if (Number.isFinite(a.value)) what += ': ' + a.value.toFixed(2) + UNIT[a.unit] + (Number.isFinite(a.limit) ? ' (limit ' + a.limit.toFixed(2) + UNIT[a.unit] + ')' : '');
    const when = a.active ? 'raised ' + a.raised_ago_s.toFixed(0) + ' s ago' : 'cleared ' + a.cleared_ago_s.toFixed(0) + ' s ago';
    return '<li class="sev-' + a.severity + (a.active ? ' active' : ' cleared') + '" data-alert-id="' + a.id + '">' +
      (a.active ? 'RAISED ' : 'cleared ') + what + ' <small>(' + when + (a.clear_condition === 2 ? ', needs acknowledge' : '') + ')</small></li>';
  }).join('') : '<li class="none">none</li>';
  if (list.innerHTML !== html) list.innerHTML = html;
}

function renderStatuses(m) {
  const kinds = ['?', 'goal', 'stop', 'acknowledge'];
  const html = m.statuses.slice().reverse().map((s) => '<li class="' + (s.accepted ? 'ok' : 'refused') + '">' +
    (kinds[s.kind] || '?') + ' from ' + s.sender_id + ': ' + (s.accepted ? 'accepted' : 'REFUSED (' + s.reason + ')') +
    ' <small>' + s.ago_s.toFixed(0) + ' s ago</small></li>').join('');
  if ($('statuses').innerHTML !== html) $('statuses').innerHTML = html;
}

// ---- staleness: the server says whether mgc's state is fresh, and the page checks that the
// server itself still speaks ----

function checkStale() {
  if (!last) {
    renderStale(null, 'no data from mgc-display yet');
    return;
  }
  const silentMs = performance.now() - lastMessageMs;
  const limitMs = config.stale_after_s * 1000;
  if (silentMs > limitMs) {
    stale = true;
    renderStale(null, 'mgc-display not answering for ' + (silentMs / 1000).toFixed(1) + ' s');
  } else if (!last.feed.alive) {
    stale = true;
    renderStale(last.feed.state_age_s, last.feed.state_age_s === null ? 'no machine state received' :
      'no MGC_MACHINE_STATE for more than ' + config.stale_after_s + ' s');
  } else {
    stale = false;
  }
}

function onMessage(event) {
  const m = JSON.parse(event.data);
  if (m.plan) plan = m.plan;
  last = m;
  lastMessageMs = performance.now();
  checkStale();
  render();
}

// ---- commands ----

async function request(path, params) {
  const res = await fetch(path, {
    method: 'POST',
    headers: { 'Content-Type': 'application/x-www-form-urlencoded' },
    body: new URLSearchParams(params || {}).toString(),
  });
  let body = {};
  try { body = await res.json(); } catch (e) { body = { error: 'HTTP ' + res.status }; }
  if (!res.ok && !body.error) body.error = 'HTTP ' + res.status;
  return body;
}

async function post(path, params) {
  const body = await request(path, params);
  const text = body.ok ? path.replace('/api/', '') + ' sent (sequence ' + body.sequence + (body.signed ? ', signed' : ', unsigned') + ')'
    : path.replace('/api/', '') + ' NOT sent: ' + (body.error || 'unexpected reply');
  setText('command-result', text);
  $('command-result').className = body.ok ? 'ok' : 'refused';
  return body;
}

// The playback's controls steer mgc-display, not mgc: the footer shows their effect with the next
// push, and the command result speaks only of one refused.
async function playback(params) {
  const body = await request('/api/playback', params);
  if (!body.error) return;
  setText('command-result', 'playback ' + params.action + ' refused: ' + body.error);
  $('command-result').className = 'refused';
}

function setupControls() {
  $('stop').addEventListener('click', () => post('/api/stop').catch((e) => setText('command-result', 'stop NOT sent: ' + e)));
  $('ack').addEventListener('click', () => post('/api/ack', { alert_id: '0' }).catch((e) => setText('command-result', 'ack NOT sent: ' + e)));
  const joints = $('goal-joints');
  const n = scene ? scene.joints.length : 0;
  for (let j = 0; j < n; j++) {
    const deg = jointUnit(j) === 'rad';
    const v = scene.goal[j];
    const label = document.createElement('label');
    label.textContent = jointName(j) + ' [' + (deg ? 'deg' : 'm') + '] ';
    const input = document.createElement('input');
    input.type = 'number';
    input.step = 'any';
    input.id = 'goal-' + j;
    input.value = deg ? (v * 180 / Math.PI).toFixed(2) : v.toFixed(3);
    label.appendChild(input);
    joints.appendChild(label);
  }
  $('goal-form').addEventListener('submit', (e) => {
    e.preventDefault();
    const values = [];
    for (let j = 0; j < n; j++) {
      const v = parseFloat($('goal-' + j).value);
      values.push(jointUnit(j) === 'rad' ? v * Math.PI / 180 : v);
    }
    post('/api/goal', { joints: values.join(',') }).catch((err) => setText('command-result', 'goal NOT sent: ' + err));
  });
  if (!config.has_key) {
    $('ack').disabled = true;
    $('goal').disabled = true;
    setText('key-note', 'No operator key given to mgc-display (--key): STOP only. Goal and acknowledge need the key.');
  } else if (!scene) {
    $('goal').disabled = true;
    setText('key-note', 'No scenario given (--scenario): no goal to request.');
  } else {
    setText('key-note', 'Signed with the operator key as sender ' + config.sender_id + '.');
  }
  if (config.playback) {
    $('playback').hidden = false;
    const failed = (e) => {
      setText('command-result', 'playback control NOT sent: ' + e);
      $('command-result').className = 'refused';
    };
    $('play').addEventListener('click', () => playback({ action: $('play').textContent === 'Pause' ? 'pause' : 'play' }).catch(failed));
    $('seek').addEventListener('change', () => playback({ action: 'seek', value: $('seek').value }).catch(failed));
    $('speed').addEventListener('change', () => playback({ action: 'speed', value: $('speed').value }).catch(failed));
  }
}

function renderPlayback(p) {
  setText('play', p.playing ? 'Pause' : 'Play');
  $('seek').max = String(p.duration_s);
  if (document.activeElement !== $('seek')) $('seek').value = String(p.position_s);
  setText('play-time', p.position_s.toFixed(1) + ' / ' + p.duration_s.toFixed(1) + ' s');
  // The speed the log plays at, also when another page (or this one before a reload) chose it;
  // a speed set through the API that the list lacks is added to it.
  const speed = $('speed'), value = String(p.speed);
  if (document.activeElement !== speed && speed.value !== value) {
    if (!Array.from(speed.options).some((o) => o.value === value)) speed.add(new Option(value));
    speed.value = value;
  }
}

async function main() {
  config = await (await fetch('/api/config')).json();
  scene = config.scene;
  if (scene) {
    setText('scenario-name', scene.name);
  } else {
    setText('view-note', 'No scenario given (--scenario F): the site and the machine are not drawn.');
  }
  if (scene) {
    setText('view-note', 'Tracked obstacles (MGC_OBSTACLE_POSES) where the controller places them: moving filled magenta, ' +
      'still filled blue, pose unknown or not current dashed red at the last pose.');
  }
  setupControls();
  const events = new EventSource('/api/events');
  events.onmessage = onMessage;
  setInterval(() => {
    const was = stale;
    checkStale();
    if (stale && !was) render();
  }, 100);
  checkStale();
  draw();
}

main().catch((e) => {
  setText('stale-banner', 'mgc-display page failed to start: ' + e);
});
