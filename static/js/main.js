import * as THREE from 'three';
import { App } from './app.js';

// Opened with ?token=: the server has set its cookie by now, which every later request
// carries. The token leaves the address bar, so it is not in the history, a bookmark
// or a screenshot of the window.
const address = new URL( window.location.href );
if ( address.searchParams.has( 'token' ) ) {

	address.searchParams.delete( 'token' );
	window.history.replaceState( window.history.state, '', address.pathname + address.search + address.hash );

}

const app = new App();
app.start();

// Read-only hook for tests and for poking at the page from the console.
window.linkview = Object.freeze( {
	get connected() {

		return app.connected;

	},
	/** The socket's state as the page reports it: connecting, connected or lost. */
	get serverState() {

		return app.socket ? app.socket.state : 'connecting';

	},
	/** True once every link mesh of every robot has loaded. */
	get meshesLoaded() {

		return app.robots.meshesLoaded;

	},
	/** Frames received so far (before coalescing), per robot name. */
	get framesReceived() {

		return Object.fromEntries( [ ...app.robots.views ].map( ( [ name, view ] ) => [ name, view.framesReceived ] ) );

	},
	/** Frames applied to the scene so far, per robot name. */
	get framesApplied() {

		return app.robots.framesApplied();

	},
	/** World matrices (16 numbers, column-major) of a robot's links in hello order, or null. */
	linkMatrices( name ) {

		return app.robots.linkMatrices( name );

	},
	/** The robots' name tags in the view: [{ robot, text, note, shown, x, y }] (x, y: the tag's foot, container px). */
	get labels() {

		return app.labels.described( app.stage );

	},
	/** What a robot's card shows: { joints (SI, the frame shown), tcp: { x, y, z, roll, pitch, yaw } as text }. */
	readout( name ) {

		return app.hud.shown( name );

	},
	/** Whether a robot is drawn, and whether it is greyed. */
	robotState( name ) {

		const view = app.robots.views.get( name );
		return view ? { visible: view.group.visible, greyed: view.greyed, posed: view.posed, note: view.note, trailPoints: view.trail.length, latencyMs: view.latencyMs, standIns: view.standIns, color: `#${view.color.getHexString()}` } : null;

	},
	/** A robot's TCP trail as drawn: [ x, y, z ] per point, base frame (m), oldest first. */
	trail( name ) {

		const view = app.robots.views.get( name );
		return view ? view.trail.points() : null;

	},
	/** The plots: which robot, how often they were redrawn, and the newest point of each. */
	get plots() {

		return { robot: app.plots.history ? app.selected : null, redraws: app.plots.redraws, redrawMs: app.plots.redrawMs, layout: app.plots.layout(), samples: app.plots.history ? app.plots.history.count : 0 };

	},
	/** The world axes' letters and the grid's spacing label: text and place on screen (CSS px). */
	get orientation() {

		return app.stage.orientation.onScreen( app.stage );

	},
	get quality() {

		return { mode: app.quality.mode, level: app.quality.level, fps: app.quality.fps, changes: app.quality.changes, settings: { ...app.stage.settings }, readoutMs: app.readoutMs };

	},
	/** A robot's Mapping table: per joint { joint, node, setpoint, unit, scale, offset, raw, value } (text as shown). */
	mapping( name ) {

		return app.mapping.shown( name );

	},
	/** A robot's setpoint ghost: { on, ghostVisible, readout, largest, recent, ghostMatrices }, or null. */
	following( name ) {

		return app.following.shown( name );

	},
	/** Commissioning: edits allowed (or why not), unsaved changes, placing, calibration, description. */
	get commission() {

		return app.commission.shown();

	},
	/** The clearance toggle: { on, text, near, highlighted: [[robot, link name], ...] }. */
	get clearance() {

		return app.clearance.shown();

	},
	/** The simulation panel: ghosts drawn, which is selected, jog requests sent. */
	get sim() {

		return { robot: app.sim.view ? app.sim.view.name : null, ghosts: app.sim.ghosts.length, selected: app.sim.selected, jogs: app.sim.jogs, moving: app.sim.moving ? { ...app.sim.moving } : null };

	},
	/** Where the camera is and what it looks at (world frame, m). */
	get camera() {

		const { position } = app.stage.camera;
		const { target } = app.stage.controls;
		return { position: position.toArray(), target: target.toArray() };

	},
	/** Where a robot lies on screen: its bounding box's projection { left, top, right, bottom } (CSS px of the view's container), or null. */
	screenBox( name ) {

		const view = app.robots.views.get( name );
		return view ? app.stage.screenBox( view.worldBox( new THREE.Box3() ) ) : null;

	},
	/** The view drawing the cell ('3d' or '2d') and its badge: { view, shown, text }. */
	get view() {

		return app.viewChoice.shown();

	},
	/** Frames drawn so far (frames with nothing new to show are not drawn). */
	get framesDrawn() {

		return app.stage.framesDrawn;

	},
	/** Draw calls and triangles of the last rendered frame. */
	get renderInfo() {

		const { calls, triangles, lines } = app.stage.renderer.info.render;
		return { calls, triangles, lines };

	},
	/** The timeline: mode (live, paused, playing), the moment shown and the live edge (unix s). */
	get timeline() {

		const { mode, moment, liveT, speed, fetches, loading } = app.timeline;
		return { mode, moment, liveT, speed, fetches, loading, span: app.timeline.span() };

	},
	get bannerChanges() {

		return app.hud.banner.changes;

	},
} );

// A page kept in the back/forward cache must come back alive: dispose only for good.
window.addEventListener( 'pagehide', ( event ) => {

	if ( ! event.persisted ) app.dispose();

} );
