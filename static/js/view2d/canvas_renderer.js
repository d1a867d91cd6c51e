import * as THREE from 'three';
import { CoarseMeshes } from './coarse.js';
import { strokeLine } from './lines.js';
import { Triangles } from './triangles.js';

// The 2D view: what the Stage (scene.js) uses of a THREE.WebGLRenderer, drawn with
// Canvas 2D, for browsers without WebGL (switched off by policy, a remote desktop or a
// thin client without a GPU, Chrome without its SwiftShader fallback) and for whoever
// picks it. It draws the same scene graph with the same camera, so poses, controls,
// labels, the timeline and the simulation work unchanged:
// - link meshes (marked `userData.meshUrl` by robots.js) from their coarse copies
//   (coarse.js), ghosts and greyed robots in the colour their material gives;
// - other meshes (stand-ins, TCP and target balls, gizmo) from their own geometry;
// - lines (grid, axes, trails, clearance boxes) and sprites (the axes' letters);
// in three passes: lines on the floor, the solids back to front, then what is drawn
// over the solids (no depth test, or a positive render order, as WebGL draws them).

const _at = new THREE.Vector3();
const _scale = new THREE.Vector3();

// What the painter reads of a mesh's geometry: positions (x, y, z) and triangles
// (3 indices each), copied once per geometry and again when it changes.
const _flat = new WeakMap();

function flatGeometry( geometry ) {

	const position = geometry.attributes.position;
	let flat = _flat.get( geometry );
	if ( flat === undefined || flat.version !== position.version || flat.count !== position.count ) {

		const positions = new Float32Array( position.count * 3 );
		for ( let i = 0; i < position.count; i ++ ) _at.fromBufferAttribute( position, i ).toArray( positions, i * 3 );
		const index = geometry.index ? geometry.index.array : Uint32Array.from( { length: position.count }, ( _, i ) => i );
		flat = { positions, index, version: position.version, count: position.count };
		_flat.set( geometry, flat );

	}
	return flat;

}

function materialOf( object ) {

	return Array.isArray( object.material ) ? object.material[ 0 ] : object.material;

}

function opacityOf( material ) {

	return material.transparent ? material.opacity : 1;

}

function cullOf( material ) {

	if ( material.side === THREE.DoubleSide ) return 0;
	return material.side === THREE.BackSide ? - 1 : 1;

}

/** The material a link mesh wears now: its own, or one for the whole link (greyed, a ghost). */
function wornMaterial( root ) {

	if ( root.isMesh ) return materialOf( root );
	for ( const child of root.children ) {

		const found = wornMaterial( child );
		if ( found ) return found;

	}
	return null;

}

/** A sprite (a label's texture) as three draws it: `sizeAttenuation` off keeps its size on screen. */
function drawSprite( ctx, sprite, camera, width, height ) {

	const material = sprite.material;
	const image = material.map && material.map.image;
	if ( ! image ) return;
	_at.setFromMatrixPosition( sprite.matrixWorld ).applyMatrix4( camera.matrixWorldInverse );
	if ( _at.z > - camera.near ) return;
	_scale.setFromMatrixScale( sprite.matrixWorld );
	const depth = material.sizeAttenuation ? - _at.z : 1;
	const p = camera.projectionMatrix.elements;
	const w = p[ 0 ] * _scale.x / depth * width / 2;
	const h = p[ 5 ] * _scale.y / depth * height / 2;
	_at.applyMatrix4( camera.projectionMatrix );
	const x = ( _at.x + 1 ) / 2 * width;
	const y = ( 1 - _at.y ) / 2 * height;
	ctx.globalAlpha = opacityOf( material );
	ctx.drawImage( image, x - w * sprite.center.x, y - h * ( 1 - sprite.center.y ), w, h );
	ctx.globalAlpha = 1;

}

const byRenderOrder = ( a, b ) => a.renderOrder - b.renderOrder;

class CanvasRenderer {

	constructor() {

		this.domElement = document.createElement( 'canvas' );
		this.domElement.setAttribute( 'aria-label', '2D view of the cell: drag to orbit, wheel to zoom, Home to reset' );
		this.domElement.setAttribute( 'role', 'img' );
		this.domElement.dataset.view = '2d';
		// On the CPU: thousands of small fills a frame are what Skia's CPU rasteriser does
		// well, and without a GPU an accelerated canvas would be SwiftShader's.
		this._ctx = this.domElement.getContext( '2d', { willReadFrequently: true } );
		this.shadowMap = { enabled: false, type: 0 };
		this.toneMapping = 0;
		this.info = { render: { calls: 0, triangles: 0, lines: 0 } };
		this.needsRedraw = false; // a coarse mesh came in since the last frame
		this.coarse = new CoarseMeshes( () => {

			this.needsRedraw = true;

		} );
		this._pixelRatio = 1;
		this._width = 1;
		this._height = 1;
		this._solids = new Triangles();
		this._overlay = new Triangles();
		this._under = [];
		this._over = [];
		this._frame = 0;
		this._loop = null;

	}

	setAnimationLoop( loop ) {

		this._loop = loop;
		cancelAnimationFrame( this._frame );
		if ( ! loop ) return;
		const step = ( time ) => {

			this._frame = requestAnimationFrame( step );
			this._loop( time );

		};
		this._frame = requestAnimationFrame( step );

	}

	setPixelRatio( ratio ) {

		this._pixelRatio = ratio;
		this.setSize( this._width, this._height );

	}

	getPixelRatio() {

		return this._pixelRatio;

	}

	/** The drawing's size in CSS px (the stage places and sizes the canvas element). */
	setSize( width, height ) {

		this._width = width;
		this._height = height;
		this.domElement.width = Math.max( 1, Math.floor( width * this._pixelRatio ) );
		this.domElement.height = Math.max( 1, Math.floor( height * this._pixelRatio ) );
		this.needsRedraw = true;

	}

	render( scene, camera ) {

		if ( scene.matrixWorldAutoUpdate ) scene.updateMatrixWorld();
		if ( camera.parent === null && camera.matrixWorldAutoUpdate ) camera.updateMatrixWorld();
		const ctx = this._ctx;
		const ratio = this.domElement.width / this._width;
		ctx.setTransform( 1, 0, 0, 1, 0, 0 );
		ctx.clearRect( 0, 0, this.domElement.width, this.domElement.height );
		ctx.setTransform( ratio, 0, 0, ratio, 0, 0 );
		ctx.lineWidth = 1;
		this._solids.clear();
		this._under.length = 0;
		this._over.length = 0;
		this._collect( scene, camera );
		const info = this.info.render;
		info.calls = 0;
		info.lines = 0;
		this._under.sort( byRenderOrder );
		this._over.sort( byRenderOrder );
		for ( const object of this._under ) this._draw( object, camera );
		info.calls += this._solids.paint( ctx );
		info.triangles = this._solids.count;
		for ( const object of this._over ) this._draw( object, camera );
		this.needsRedraw = false;

	}

	// Walk the visible scene: solids go to the painter, the rest to the passes before and after.
	_collect( object, camera ) {

		if ( ! object.visible ) return;
		const url = object.userData.meshUrl;
		if ( url !== undefined ) {

			const parts = this.coarse.get( url );
			if ( parts !== null ) {

				this._addCoarse( object, parts, camera );
				return;

			}
			if ( ! this.coarse.failed( url ) ) return; // still on its way

		}
		const material = object.material ? materialOf( object ) : null;
		if ( material && material.visible && ! material.isShadowMaterial ) {

			const over = material.depthTest === false || object.renderOrder > 0;
			if ( object.isMesh && ! over ) this._addMesh( this._solids, object, camera );
			else if ( object.isMesh || object.isSprite || ( object.isLine && over ) ) this._over.push( object );
			else if ( object.isLine ) this._under.push( object );

		}
		for ( const child of object.children ) this._collect( child, camera );

	}

	_addCoarse( root, parts, camera ) {

		const worn = wornMaterial( root );
		const whole = worn && worn.userData.wholeLink ? worn : null;
		for ( const part of parts ) {

			const color = whole ? whole.color : part.color;
			const opacity = whole ? opacityOf( whole ) : part.opacity;
			this._solids.add( part.positions, part.index, root.matrixWorld, camera, this._width, this._height, color, opacity );

		}

	}

	_addMesh( triangles, mesh, camera ) {

		const material = materialOf( mesh );
		const { positions, index } = flatGeometry( mesh.geometry );
		const color = material.color || new THREE.Color( 0xffffff );
		triangles.add( positions, index, mesh.matrixWorld, camera, this._width, this._height, color, opacityOf( material ), material.isMeshBasicMaterial, cullOf( material ) );

	}

	_draw( object, camera ) {

		const info = this.info.render;
		if ( object.isMesh ) {

			this._overlay.clear();
			this._addMesh( this._overlay, object, camera );
			info.calls += this._overlay.paint( this._ctx );

		} else if ( object.isSprite ) {

			drawSprite( this._ctx, object, camera, this._width, this._height );
			info.calls ++;

		} else {

			info.lines += strokeLine( this._ctx, object, camera, this._width, this._height );
			info.calls ++;

		}

	}

	dispose() {

		this.setAnimationLoop( null );

	}

}

export { CanvasRenderer };
