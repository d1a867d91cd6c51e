import { Hud } from './hud.js';
import { Labels } from './labels.js';
import { Robots } from './robots.js';
import { Stage } from './scene.js';
import { Socket } from './socket.js';

const PROTOCOL = 1; // server/protocol.py PROTOCOL_VERSION
const HUD_INTERVAL_MS = 100;
const FRAME_ANYWAY_MS = 3000; // aim the camera even if a robot never gets a good pose

/**
 * The viewer: wires the socket to the robots and the HUD, and runs the render
 * loop, which applies at most one (the newest) frame per robot per animation frame.
 */
class App {

	constructor( root = document ) {

		this.stage = new Stage( root.getElementById( 'viewport' ) );
		this.robots = new Robots( this.stage.world );
		this.hud = new Hud( root );
		this.labels = new Labels( root.getElementById( 'labels' ) );
		this.socket = null;
		this.protocolError = null;
		this._hudAt = - Infinity;
		this._dressed = false; // HUD and labels use the colours picked from the meshes
		this._framed = false;
		this._loadedAt = null;
		this._animate = ( time ) => this.animate( time );
		this._receive = ( message ) => this.receive( message );

	}

	start() {

		this.socket = new Socket( {
			onMessage: this._receive,
			onState: ( state, retryAt ) => this.hud.setConnection( state, retryAt ),
		} );
		this.stage.renderer.setAnimationLoop( this._animate );

	}

	get connected() {

		return this.socket !== null && this.socket.state === 'connected';

	}

	receive( message ) {

		switch ( message.type ) {

			case 'hello': this._onHello( message ); break;
			case 'frame': this.robots.queue( message ); break;
			case 'status': this.hud.setStatus( message ); break;
			case 'cell': this.hud.setCell( message ); break;
			default: console.warn( 'linkview: unknown message type', message.type );

		}

	}

	_onHello( hello ) {

		this.protocolError = hello.protocol === PROTOCOL
			? null
			: `The server speaks protocol ${hello.protocol}; this page expects ${PROTOCOL}. Reload the page.`;
		const rebuilt = this.robots.setHello( hello );
		this.hud.setHello( hello, this.robots.views );
		if ( rebuilt ) {

			this.labels.rebuild( this.robots.views );
			this._dressed = false;
			this._framed = false;
			this._loadedAt = null;

		}

	}

	animate( time ) {

		this.robots.applyPending();
		const views = this.robots.views;

		if ( this.robots.meshesLoaded && ! this._dressed ) {

			this._dressed = true;
			this._loadedAt = time;
			this.hud.refreshColors( views );
			this.labels.refreshColors( views );

		}
		if ( this._dressed && ! this._framed && ( this.robots.allPosed() || time - this._loadedAt > FRAME_ANYWAY_MS ) ) {

			this._framed = true;
			this.stage.frameWorld();

		}
		if ( this._framed ) for ( const view of views.values() ) view.updateAnchor();
		if ( time - this._hudAt >= HUD_INTERVAL_MS ) {

			this._hudAt = time;
			this.hud.update( views, this.protocolError || this.robots.loadError );

		}
		this.stage.render();
		this.labels.update( views, this.stage.camera );

	}

	dispose() {

		if ( this.socket ) this.socket.dispose();
		this.stage.renderer.setAnimationLoop( null );
		this.labels.dispose();
		this.robots.dispose();
		this.stage.dispose();

	}

}

export { App };
