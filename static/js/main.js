import { App } from './app.js';

const app = new App();
app.start();

// Read-only hook for tests and for poking at the page from the console.
window.linkview = Object.freeze( {
	get connected() {

		return app.connected;

	},
	/** True once every link mesh of every robot has loaded. */
	get meshesLoaded() {

		return app.robots.meshesLoaded;

	},
	/** Frames applied to the scene so far, per robot name. */
	get framesApplied() {

		return app.robots.framesApplied();

	},
	/** World matrices (16 numbers, column-major) of a robot's links in hello order, or null. */
	linkMatrices( name ) {

		return app.robots.linkMatrices( name );

	},
} );

// A page kept in the back/forward cache must come back alive: dispose only for good.
window.addEventListener( 'pagehide', ( event ) => {

	if ( ! event.persisted ) app.dispose();

} );
