import { ClearanceWarning } from './clearance.js';
import { Commissioning } from './commission.js';
import { ServerClock, nowMs } from './clock.js';
import { Following } from './following.js';
import { Hud } from './hud.js';
import { Labels } from './labels.js';
import { MappingTables } from './mapping.js';
import { probeWebGL } from './no_webgl.js';
import { Panels } from './panels.js';
import { JointPlots } from './plots.js';
import { LEVELS, Quality } from './quality.js';
import { Robots } from './robots.js';
import { Stage } from './scene.js';
import { SimPanel } from './sim.js';
import { Socket } from './socket.js';
import { Timeline } from './timeline.js';
import { ViewChoice, askedView } from './view2d/choice.js';

const PROTOCOL = 2; // server/protocol.py PROTOCOLS['linkview.2']
// Every DOM readout (cards, plots, timeline, simulation) changes in one animation frame,
// ten times a second; the frames between touch only the 3D view. Each DOM change is
// painted and rasterised again, and without a GPU that raster competes with the view:
// there, four times a second (in Chromium's default path, 45.9 -> 50.4 frames/s with the
// demo cell; bench/page_fps.py).
const READOUT_INTERVAL_MS = 100;
const SOFTWARE_READOUT_INTERVAL_MS = 250;
const FRAME_ANYWAY_MS = 3000; // aim the camera even if a robot never gets a pose
const LATENCY_SMOOTHING = 0.1; // weight of the newest sample in the latency average

/**
 * The viewer: wires the socket to the robots, the panels and the scene, and runs
 * the render loop, which applies at most one (the newest) frame per robot per
 * animation frame.
 */
class App {

	constructor( root = document ) {

		this.root = root;
		// Software WebGL starts 'auto' at the lowest level rather than spending seconds at
		// levels it cannot carry (and climbs if it has headroom); the stage is built at it.
		const webgl = probeWebGL();
		this.quality = new Quality( ( settings ) => this.stage.setQuality( settings ), Math.min( window.devicePixelRatio, 2 ), webgl?.software ? LEVELS.length - 1 : 0 );
		this.readoutMs = webgl === null || webgl.software ? SOFTWARE_READOUT_INTERVAL_MS : READOUT_INTERVAL_MS;
		this.stage = new Stage( root.getElementById( 'viewport' ), this.quality.settings(), { webgl: webgl !== null, view: askedView() } );
		this.viewChoice = new ViewChoice( root, this.stage ); // 3D or 2D, and the 2D view's badge
		this.robots = new Robots( this.stage.world );
		this.hud = new Hud( root, {
			onShow: ( name, on ) => this.setShown( name, on ),
			onTrail: ( name, on ) => this.views.get( name )?.setTrail( on ),
			onFocus: ( name ) => this.focus( name ),
		} );
		this.labels = new Labels( this.stage.scene );
		this.commission = new Commissioning( root, this.stage ); // docs/commissioning.md
		this.mapping = new MappingTables( root, this.commission.mapping.decorate );
		this.following = new Following( root, this.stage.world );
		this.clock = new ServerClock();
		this.plots = new JointPlots( root.getElementById( 'plots' ), root.getElementById( 'plot-velocity' ), root.getElementById( 'plot-filter' ) );
		this.sim = new SimPanel( root, this.stage );
		this.clearance = new ClearanceWarning( root, this.stage, this.robots );
		this.panels = new Panels( root, ( left, right, bottom ) => {

			this.stage.setInsets( left, right, bottom );
			this.plots.resize();

		} );
		this.socket = null;
		this.protocolError = null;
		this.selected = null; // robot name shown in the plots and the simulation panel
		this.trailSeconds = 5;
		this._readoutAt = - Infinity;
		this._dressed = false; // the HUD uses the colours picked from the meshes
		this._framed = false;
		this._helloAt = null;
		this._animate = ( time ) => this.animate( time );
		this.timeline = new Timeline( root, this ); // look back: the last minutes, from the server's history
		this._wire();

	}

	get views() {

		return this.robots.views;

	}

	_wire() {

		const byId = ( id ) => this.root.getElementById( id );
		byId( 'fit-all' ).addEventListener( 'click', () => this.fitAll() );
		for ( const el of this.root.querySelectorAll( '[data-view]' ) ) {

			el.addEventListener( 'click', () => this.fitAll( el.dataset.view ) );

		}
		const trailOn = byId( 'trail-on' );
		trailOn.addEventListener( 'change', () => {

			for ( const view of this.views.values() ) view.setTrail( trailOn.checked );
			for ( const input of this.root.querySelectorAll( '#robots input[aria-label^="draw the TCP trail"]' ) ) input.checked = trailOn.checked;

		} );
		const labelsOn = byId( 'labels-on' );
		labelsOn.addEventListener( 'change', () => {

			this.labels.shown = labelsOn.checked;

		} );
		const seconds = byId( 'trail-seconds' );
		seconds.addEventListener( 'change', () => {

			const value = Number( seconds.value );
			if ( Number.isFinite( value ) && value > 0 ) this.trailSeconds = Math.min( value, 60 );

		} );
		const quality = byId( 'quality' );
		for ( const [ i, level ] of LEVELS.entries() ) {

			const option = document.createElement( 'option' );
			option.value = String( i );
			option.textContent = level.name;
			quality.append( option );

		}
		quality.addEventListener( 'change', () => this.quality.setMode( quality.value === 'auto' ? 'auto' : Number( quality.value ) ) );
		// ?quality=N pins a level from the start (a bookmark for a slow machine; tests, benchmarks).
		const pinned = new URLSearchParams( window.location.search ).get( 'quality' );
		if ( pinned !== null && quality.querySelector( `option[value="${CSS.escape( pinned )}"]` ) ) {

			quality.value = pinned;
			this.quality.setMode( pinned === 'auto' ? 'auto' : Number( pinned ) );

		}
		byId( 'selected-robot' ).addEventListener( 'change', ( event ) => this.select( event.target.value ) );
		this._onKey = ( event ) => {

			if ( event.key !== 'Home' || event.target.closest?.( 'input, select, textarea' ) ) return;
			event.preventDefault();
			this.fitAll( 'iso' );

		};
		window.addEventListener( 'keydown', this._onKey );

	}

	start() {

		this.socket = new Socket( {
			onMessage: ( message, arrival ) => this.receive( message, arrival ),
			onFrames: ( frames, arrival ) => this.receiveFrames( frames, arrival ),
			onState: ( state ) => this.hud.setConnection( state ),
		} );
		this.stage.setAnimationLoop( this._animate );

	}

	get connected() {

		return this.socket !== null && this.socket.state === 'connected';

	}

	receive( message, arrival = nowMs() ) {

		switch ( message.type ) {

			case 'hello': this._onHello( message ); break;
			case 'frame': this.clock.observe( message.t_sent, arrival ); this.timeline.noteLive( message.t_source ); this._queue( message, arrival ); break;
			case 'status': this.hud.setStatus( message ); break;
			case 'cell': this.hud.setCell( message ); break;
			case 'clearance': this.clearance.update( message ); break;
			default: console.warn( 'linkview: unknown message type', message.type );

		}

	}

	/** A protocol-2 frames message: every robot of one source at one sample. */
	receiveFrames( frames, arrival ) {

		this.clock.observe( frames.t_sent, arrival );
		this.timeline.noteLive( frames.t_source );
		for ( const entry of frames.robots ) {

			const view = this.robots.byIndex[ entry.robot_index ];
			if ( view === undefined ) {

				this.robots.unknownFrames ++;
				continue;

			}
			// The same shape as a protocol-1 `frame` (links flat: 7 numbers per link).
			this._queue( {
				type: 'frame', robot: view.name, seq: frames.seq, t_source: frames.t_source, t_sent: frames.t_sent,
				joints: entry.joints, links: entry.links, tcp: entry.tcp, ok: entry.ok, error: entry.error,
				setpoint: entry.setpoint,
			}, arrival );

		}

	}

	_queue( frame, arrival ) {

		this.following.received( frame, arrival );
		this.robots.queue( frame, arrival );

	}

	_onHello( hello ) {

		this.protocolError = hello.protocol === PROTOCOL
			? null
			: `The server speaks protocol ${hello.protocol}; this page expects ${PROTOCOL}. Reload the page.`;
		const rebuilt = this.robots.setHello( hello );
		this.hud.setHello( hello, this.views );
		this.mapping.setHello( hello );
		this.following.setHello( hello, this.views );
		this.commission.setHello();
		if ( ! rebuilt ) return;
		this.timeline.goLive(); // the history shown described the robots gone by
		this.labels.rebuild( this.views );
		this._dressed = false;
		this._framed = false;
		this._helloAt = performance.now();
		const select = this.root.getElementById( 'selected-robot' );
		select.replaceChildren( ...hello.robots.map( ( robot ) => new Option( robot.name, robot.name ) ) );
		const keep = this.views.has( this.selected ) ? this.selected : hello.robots[ 0 ]?.name ?? null;
		this.select( keep );

	}

	/** Show `name`'s joints in the plots and its simulation panel. */
	select( name ) {

		this.selected = name;
		const select = this.root.getElementById( 'selected-robot' );
		if ( name !== null ) select.value = name;
		const view = this.views.get( name ) ?? null;
		const history = view ? this.timeline.plotHistory( name ) ?? this.robots.histories.get( name ) : null;
		this.plots.show( history, view ? `#${view.color.getHexString()}` : '' );
		this.sim.setRobot( view );
		this.commission.setRobot( view, this.views );

	}

	setShown( name, on ) {

		const view = this.views.get( name );
		if ( ! view ) return;
		view.setShown( on );
		if ( ! on && this.sim.view === view ) this.sim.setRobot( view ); // its ghosts go too

	}

	_visibleViews() {

		return [ ...this.views.values() ].filter( ( view ) => view.group.visible );

	}

	/** Frame every shown robot, from a preset direction or the current one. */
	fitAll( preset = null ) {

		return this.stage.frameAll( this._visibleViews(), preset );

	}

	focus( name ) {

		const view = this.views.get( name );
		if ( view ) this.stage.frameAll( [ view ] );

	}

	animate( time ) {

		const now = nowMs();
		this.timeline.tick( time );
		this.clearance.tick();
		// While the timeline shows the past, live frames wait (newest only) for Live.
		for ( const frame of this.timeline.live ? this.robots.applyPending( now ) : [] ) {

			const view = this.views.get( frame.robot );
			this.following.applied( frame );
			const age = this.clock.ageMs( frame.t_source, now );
			if ( age !== null ) view.latencyMs = view.latencyMs === null ? age : view.latencyMs + LATENCY_SMOOTHING * ( age - view.latencyMs );

		}
		const views = this.views;
		if ( this.robots.meshesLoaded && ! this._dressed ) {

			this._dressed = true;
			this.hud.refreshColors( views );
			if ( this.selected ) this.select( this.selected ); // plot colours

		}
		if ( this._dressed && ! this._framed ) {

			const posed = [ ...views.values() ].every( ( view ) => view.posed );
			if ( posed || time - this._helloAt > FRAME_ANYWAY_MS ) this._framed = this.fitAll( 'iso' ) || ! posed;

		}
		for ( const view of views.values() ) {

			view.trail.seconds = this.trailSeconds;
			if ( view.trailOn ) view.trail.update( this.timeline.trailNow( now ) );
			if ( this._framed ) view.updateAnchor();

		}
		if ( time - this._readoutAt >= this.readoutMs ) {

			this._readoutAt = time;
			this._updateStates();
			this.hud.update( views, this.clock, this.protocolError || this.robots.loadError );
			this.mapping.update( views );
			this.following.update( now );
			this.sim.update();
			const drawing = this.stage.view === '2d' ? '2D view' : LEVELS[ this.quality.level ].name;
			this.root.getElementById( 'fps' ).textContent = `${this.quality.fps.toFixed( 0 )} frames/s · ${drawing}`;
			this.timeline.refresh();
			this.plots.redraw();

		}
		this.labels.update( views, this.stage );
		this.quality.tick( time, this.stage.render() ); // frames that showed nothing new are not counted

	}

	// Grey and a note for every robot that is not live: no frame yet, in error, or its source is down.
	_updateStates() {

		const simple = this.stage.simpleMaterials;
		for ( const view of this.views.values() ) {

			view.setSimple( simple );
			const live = this.hud.sourceLive( view.info.source );
			let note = null;
			if ( view.error ) note = view.error;
			else if ( view.goodFrame === null ) note = view.zeroPosed ? 'no frame yet (zero pose)' : 'no frame yet';
			else if ( ! live ) note = `no live data from ${view.info.source}`;
			view.note = note;
			view.setGreyed( note !== null );

		}

	}

	dispose() {

		if ( this.socket ) this.socket.dispose();
		this.timeline.dispose();
		window.removeEventListener( 'keydown', this._onKey );
		this.stage.setAnimationLoop( null );
		this.sim.dispose();
		this.commission.dispose();
		this.following.dispose();
		this.plots.dispose();
		this.panels.dispose();
		this.labels.dispose();
		this.robots.dispose();
		this.stage.dispose();

	}

}

export { App };
