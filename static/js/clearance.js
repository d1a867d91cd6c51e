import * as THREE from 'three';
import { wantClearance } from './api.js';

// The server's clearance check (server/clearance, docs/protocol.md `clearance`):
// it measures the links of different robots ten times a second while some page
// asks for it (a lease of 10 s, renewed while the toggle is on).
const HIGHLIGHT = 0xe02020;
const RENEW_MS = 4000;

/** "Clearance" toggle: the nearest links of different robots, named, with a box around each. */
class ClearanceWarning {

	constructor( root, stage, robots ) {

		this.robots = robots; // its views are replaced on each hello
		this.toggle = root.getElementById( 'clearance-on' );
		this.line = root.getElementById( 'clearance' );
		this.clearance = null; // newest message
		this.boxes = [ new THREE.BoxHelper( undefined, HIGHLIGHT ), new THREE.BoxHelper( undefined, HIGHLIGHT ) ];
		for ( const box of this.boxes ) {

			box.visible = false;
			box.material.depthTest = false; // seen through the links that hide it
			box.renderOrder = 10;
			stage.scene.add( box );

		}
		this._renew = 0;
		this.toggle.addEventListener( 'change', () => {

			clearInterval( this._renew );
			if ( this.on ) {

				this._ask();
				this._renew = setInterval( () => this._ask(), RENEW_MS );

			}
			this._show();

		} );

	}

	_ask() {

		wantClearance().catch( () => {} ); // the socket's state tells of a server that is away

	}

	get on() {

		return this.toggle.checked;

	}

	update( clearance ) {

		this.clearance = clearance;
		this._show();

	}

	/** Once per animation frame: the boxes follow the links they mark. */
	tick() {

		for ( const box of this.boxes ) if ( box.visible && box.object ) box.update();

	}

	/** What the toggle shows now: { on, text, near (pairs), highlighted ([robot, link name] pairs) }. */
	shown() {

		return {
			on: this.on,
			text: this.line.hidden ? '' : this.line.textContent,
			near: this.clearance ? this.clearance.near.length : 0,
			highlighted: this.boxes.filter( ( box ) => box.visible ).map( ( box ) => [ box.userData.robot, box.object.name ] ),
		};

	}

	_show() {

		const clearance = this.clearance;
		this.line.hidden = ! this.on;
		for ( const box of this.boxes ) box.visible = false;
		if ( ! this.on ) return;
		if ( clearance === null ) {

			this.line.textContent = 'Clearance: waiting for the server';
			return;

		}
		const mm = ( m ) => `${Math.round( m * 1000 )} mm`;
		if ( clearance.near.length === 0 ) {

			this.line.textContent = `Clearance: no links of different robots within ${mm( clearance.within_m )}`;
			this.line.classList.remove( 'warn' );
			return;

		}
		const texts = clearance.near.map( ( near ) => {

			const [ a, b ] = near.robots;
			const [ la, lb ] = near.link_names;
			const apart = near.distance_m > 0 ? `${mm( near.distance_m )} apart` : 'touching';
			return `${a} ${la} and ${b} ${lb}: ${apart}`;

		} );
		this.line.textContent = `Clearance: ${texts.join( '; ' )}`;
		this.line.classList.add( 'warn' );
		const nearest = clearance.near[ 0 ];
		nearest.robots.forEach( ( robot, k ) => {

			const node = this.robots.views.get( robot )?.nodes[ nearest.links[ k ] ];
			if ( ! node ) return;
			const box = this.boxes[ k ];
			box.setFromObject( node );
			box.userData.robot = robot;
			box.visible = true;

		} );

	}

	dispose() {

		clearInterval( this._renew );
		for ( const box of this.boxes ) {

			box.removeFromParent();
			box.geometry.dispose();
			box.material.dispose();

		}

	}

}

export { ClearanceWarning };
