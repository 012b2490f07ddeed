// SPDX-License-Identifier: MIT
// The script of the page `wetgraph watch --serve` serves (web/index.html; cli/serve.c): it reads
// /api/state, builds a control for each <param> from its declaration (a slider for a float or
// int with a min and a max, a number box otherwise, a checkbox for a bool, a menu for an enum, a
// colour picker for a colour, a text box for a string), shows every output's PNG preview scaled
// to fit (a click enlarges it to the page's width), the value under the cursor, the graph
// (/graph.svg, linked to itself at full size, or a list of its nodes when the server has no
// picture), the per-node times of the last render, the last error and the `wetgraph render`
// command line that reproduces the current state. A gray output can be shown through a colour
// map (viridis, from ten of its colours, or turbo, from its polynomial approximation), for the
// page or per output: the browser draws the gray preview onto a canvas through a 256-entry
// table, so the server keeps serving only its previews. When the graph reads $time the page
// shows a time slider and play/pause: playing sets $time, waits for that render and only then
// asks for the next frame (one render in flight), advancing by the time that passed (at least
// 1/30 s) and wrapping at the slider's end. /events announces each finished render, and the
// page then reloads the state and the images. The page address takes ?set=name=value
// (repeatable; applied once on load), ?cmap=viridis|turbo (the page's colour map), ?big=OUTPUT
// (shown enlarged), ?play=N (play N frames, then pause) and ?events=0 (leave /events closed and,
// while playing, wait for each frame with /api/state?after=V: for headless browsers, whose
// virtual clock stands still while a request is open, which an open /events would be for ever).
// A change is POSTed to /api/set as a form, with the run's token (the server fills it into the
// page's <meta name="wetgraph-token">) in the X-Wetgraph-Token header; ?set= and ?play= are
// applied only when the server marks the page's <meta name="wetgraph-address-settings"> with 1
// (not when another site's page sent the browser here).
'use strict';
let built=false,version=-1,state=null,svgv=null,viewDone=null;
const args=new URLSearchParams(location.search);
function q(s){return s.includes(' ')||s.includes('"')||s===''?"'"+s.replace(/'/g,"'\\''")+"'":s}
// a change: POSTed as a form with the run's token, which only this page has
const token=document.querySelector('meta[name=wetgraph-token]').content;
function send(name,value){return fetch('/api/set',{method:'POST',headers:{'X-Wetgraph-Token':token},body:new URLSearchParams([[name,value]])})}
function toHex(v){if(/^#[0-9a-fA-F]{6}$/.test(v))return v;if(/^#[0-9a-fA-F]{3}$/.test(v))return '#'+v[1]+v[1]+v[2]+v[2]+v[3]+v[3];if(/^#[0-9a-fA-F]{8}$/.test(v))return v.slice(0,7);let n=v.trim().split(/\s+/).map(Number);if(n.length===1)n=[n[0],n[0],n[0]];return '#'+n.slice(0,3).map(x=>{x=Math.min(1,Math.max(0,x||0));x=x<=0.0031308?12.92*x:1.055*Math.pow(x,1/2.4)-0.055;return Math.round(x*255).toString(16).padStart(2,'0')}).join('')}
// colour maps for gray outputs, 256 entries of [r,g,b]: viridis from ten of its colours
// (interpolated), turbo from its polynomial approximation
const maps={gray:null,viridis:null,turbo:null};
(function(){const v=['440154','482878','3e4989','31688e','26828e','1f9e89','35b779','6ece58','b5de2b','fde725'].map(h=>[0,2,4].map(k=>parseInt(h.substr(k,2),16)));
const vi=[],tu=[];for(let i=0;i<256;i++){const x=i/255*9,k=Math.min(8,Math.floor(x)),f=x-k;vi.push([0,1,2].map(c=>Math.round(v[k][c]+(v[k+1][c]-v[k][c])*f)));
const t=i/255,p=(a)=>Math.round(255*Math.min(1,Math.max(0,a[0]+t*(a[1]+t*(a[2]+t*(a[3]+t*(a[4]+t*a[5])))))));
tu.push([p([0.13572138,4.6153926,-42.66032258,132.13108234,-152.94239396,59.28637943]),p([0.09140261,2.19418839,4.84296658,-14.18503333,4.27729857,2.82956604]),p([0.1066733,12.64194608,-60.58204836,110.36276771,-89.90310912,27.34824973])])}
maps.viridis=vi;maps.turbo=tu})();
// A control for parameter p: its short label (the name beside it, the description as the
// tooltip), and by type a checkbox, a menu, a colour picker, a text box, or for a number a
// number box that takes any value of the hard range, with a slider over the soft range
// (soft_min..soft_max, else the hard range; its step, else 1/1000 of the range or 1 for an int)
// when the slider has both ends; a number also gets a reset to its default.
function control(p){
 const d=document.createElement('div');d.className='p';d.id='row-'+p.name;
 if(p.description)d.title=p.description;
 const l=document.createElement('label');l.textContent=p.label||p.name;
 if(p.label){const n=document.createElement('span');n.className='pname';n.textContent=' '+p.name;l.appendChild(n)}
 d.appendChild(l);
 let i;
 const numeric=p.type==='float'||p.type==='int';
 const lo=p.soft_min!==undefined?p.soft_min:p.min,hi=p.soft_max!==undefined?p.soft_max:p.max;
 if(p.type==='bool'){i=document.createElement('input');i.type='checkbox';i.checked=p.value==='true'||p.value==='1';i.onchange=()=>send(p.name,i.checked?'true':'false')}
 else if(p.type==='enum'){i=document.createElement('select');for(const v of p.values){const o=document.createElement('option');o.value=o.textContent=v;i.appendChild(o)}i.value=p.value;i.onchange=()=>send(p.name,i.value)}
 else if(p.type==='color'){i=document.createElement('input');i.type='color';i.value=toHex(p.value);i.oninput=()=>send(p.name,i.value)}
 else if(numeric&&lo!==undefined&&hi!==undefined){
  i=document.createElement('input');i.type='range';i.min=lo;i.max=hi;
  i.step=p.step!==undefined?p.step:p.type==='int'?1:(hi-lo)/1000;i.value=p.value}
 else{i=document.createElement('input');i.type=p.type==='string'?'text':'number';if(p.type==='int')i.step=1;else if(p.type==='float')i.step='any';i.value=p.value;i.onchange=()=>send(p.name,i.value)}
 i.id='param-'+p.name;i.dataset.name=p.name;d.appendChild(i);
 if(i.type==='range'){
  // the number box: exact values, beyond the slider's soft range as far as the hard range
  const box=document.createElement('input');box.type='number';box.id='num-'+p.name;box.className='num';
  if(p.min!==undefined)box.min=p.min;if(p.max!==undefined)box.max=p.max;
  box.step=p.type==='int'?1:'any';box.value=p.value;
  i.oninput=()=>{box.value=i.value;send(p.name,i.value)};
  box.onchange=()=>{if(box.value==='')return;i.value=box.value;send(p.name,box.value)};
  d.appendChild(box)}
 if(numeric||p.type==='color'){
  const r=document.createElement('button');r.className='reset';r.id='reset-'+p.name;r.textContent='\u21ba';
  r.title='reset to the default, '+p.default;
  r.onclick=()=>{setShown(p.name,p.default);send(p.name,p.default)};
  d.appendChild(r)}
 return d}
// show value v in the controls of parameter name (not while one of them is being edited)
function setShown(name,v){
 const i=document.getElementById('param-'+name),box=document.getElementById('num-'+name);
 if(!i||i===document.activeElement||(box&&box===document.activeElement))return;
 if(i.type==='checkbox')i.checked=v==='true'||v==='1';else if(i.type==='color')i.value=toHex(v);else i.value=v;
 if(box)box.value=v}
// parameters NAME_r, NAME_g, NAME_b (floats within -1..1, negative: a preset's) get one colour
// picker that sets the three (linear, from the picker's sRGB) and a button back to the preset
function triplet(base,ps){
 const d=document.createElement('div');d.className='p';d.id='rgb-'+base;
 const l=document.createElement('label');l.textContent=base+' colour';d.appendChild(l);
 const c=document.createElement('input');c.type='color';c.id='color-'+base;
 const lin=x=>{x/=255;return x<=0.04045?x/12.92:Math.pow((x+0.055)/1.055,2.4)};
 c.oninput=()=>{const h=c.value,form=new URLSearchParams();
  ['r','g','b'].forEach((k,n)=>{const v=lin(parseInt(h.substr(1+2*n,2),16)).toFixed(4);form.append(base+'_'+k,v);setShown(base+'_'+k,v)});
  sendForm(form)};
 d.appendChild(c);
 if(ps.every(p=>p.min<0)){const b=document.createElement('button');b.textContent='preset';b.title='the preset\'s colour (all three negative)';
  b.onclick=()=>{const form=new URLSearchParams();for(const p of ps){form.append(p.name,'-1');setShown(p.name,'-1')}sendForm(form)};d.appendChild(b)}
 return d}
function sendForm(form){return fetch('/api/set',{method:'POST',headers:{'X-Wetgraph-Token':token},body:form})}
// the controls, in groups (in the order they first appear; folding), ungrouped ones first
function buildParams(params){
 const ps=document.getElementById('params'),groups=new Map();
 const byName=new Map(params.map(p=>[p.name,p]));
 for(const p of params){
  let box=ps;
  if(p.group){if(!groups.has(p.group)){const g=document.createElement('details');g.open=true;g.className='group';g.dataset.group=p.group;
    const sm=document.createElement('summary');sm.textContent=p.group;g.appendChild(sm);groups.set(p.group,g)}box=groups.get(p.group)}
  const m=/^(.*)_r$/.exec(p.name);
  if(m&&p.type==='float'&&p.min>=-1&&p.max<=1){const t=['g','b'].map(k=>byName.get(m[1]+'_'+k));
   if(t.every(x=>x&&x.type==='float'))box.appendChild(triplet(m[1],[p].concat(t)))}
  box.appendChild(control(p))}
 for(const g of groups.values())ps.appendChild(g)}
// the map a figure shows: its own choice, else the page's
function mapOf(f){const s=f.querySelector('select');return s&&s.value!=='page'?s.value:document.getElementById('cmap').value}
// draw a figure: its image as it is, or a gray output through a colour map on its canvas
function paint(f){
 const im=f.querySelector('img'),cv=f.querySelector('canvas');if(!im.naturalWidth)return;
 const w=im.naturalWidth,h=im.naturalHeight;
 if(!f.px||f.pxsrc!==im.src){const c=document.createElement('canvas');c.width=w;c.height=h;const x=c.getContext('2d',{willReadFrequently:true});x.drawImage(im,0,0);f.px=x.getImageData(0,0,w,h);f.pxsrc=im.src}
 const m=f.dataset.channels==='1'?mapOf(f):'gray';f.dataset.map=m;
 if(m==='gray'){cv.hidden=true;im.hidden=false;delete f.dataset.sample;return}
 cv.width=w;cv.height=h;const x=cv.getContext('2d',{willReadFrequently:true}),o=x.createImageData(w,h),lut=maps[m],s=f.px.data,d=o.data;
 for(let k=0;k<s.length;k+=4){const c=lut[s[k]];d[k]=c[0];d[k+1]=c[1];d[k+2]=c[2];d[k+3]=255}
 x.putImageData(o,0,0);cv.hidden=false;im.hidden=true;
 f.dataset.sample=Array.from(x.getImageData(w>>1,h>>1,1,1).data.slice(0,3)).join(',')}
// the value under the cursor (the preview's: 8 bits, 0..1 for gray maps)
function readout(f,e){
 const el=e.target,px=f.px;if(!px)return;
 const cw=el.clientWidth,ch=el.clientHeight,sc=Math.min(cw/px.width,ch/px.height);
 const x=Math.floor((e.offsetX-(cw-px.width*sc)/2)/sc),y=Math.floor((e.offsetY-(ch-px.height*sc)/2)/sc);
 const v=f.querySelector('.v');if(x<0||y<0||x>=px.width||y>=px.height){v.textContent='';return}
 const k=4*(y*px.width+x),d=px.data;
 v.textContent=x+','+y+': '+(f.dataset.channels==='1'?(d[k]/255).toFixed(3):d[k]+' '+d[k+1]+' '+d[k+2])}
function figure(o){
 const f=document.createElement('figure');f.id='out-'+o.name;f.dataset.channels=o.channels;
 const im=document.createElement('img');im.alt=o.name;const cv=document.createElement('canvas');cv.hidden=true;
 im.onload=()=>{paint(f);f.dataset.loaded=im.src};
 for(const el of [im,cv]){el.onclick=()=>f.classList.toggle('big');el.onmousemove=e=>readout(f,e);el.onmouseleave=()=>{f.querySelector('.v').textContent=''}}
 const c=document.createElement('figcaption');const n=document.createElement('span');n.textContent=o.name;c.appendChild(n);
 if(o.channels===1){const s=document.createElement('select');for(const v of ['page','gray','viridis','turbo']){const op=document.createElement('option');op.value=v;op.textContent=v==='page'?'map: as the page':v;s.appendChild(op)}s.onchange=()=>paint(f);c.appendChild(s)}
 const v=document.createElement('span');v.className='v';c.appendChild(v);
 f.appendChild(im);f.appendChild(cv);f.appendChild(c);
 // the zones view of create_masks: what its colours mean (its zones node: 0.75 of red,
 // yellow, orange or blue over the gray height)
 if(o.name==='zones'){const lg=document.createElement('div');lg.className='legend';lg.id='zones-legend';
  for(const [t,col] of [['immersed','#bf0000'],['wet','#bfbf00'],['puddles','#bf6000'],['moist','#0030bf'],['dry: the height, gray','#808080']]){
   const k=document.createElement('span');const sw=document.createElement('i');sw.style.background=col;k.append(sw,t);lg.appendChild(k)}
  f.appendChild(lg)}
 if(args.get('big')===o.name)f.classList.add('big');return f}
// The graph: dot's picture, put in the page as SVG so that its nodes can be clicked (parsed, not
// run: scripts, foreign objects, links and event attributes are dropped), with a link to it at
// full size; without a picture, the list of the nodes. A click on a node (a box of the picture,
// an item of the list) asks the server for that node's image ($view), shown as the first map.
async function pick(id){
 let v=version;await send('$view',id);
 // until the state has that node's image (or why not), or, for none, no view
 for(;;){await rendered(v);v=version;const w=state.view;if(id?w&&w.asked===id&&w.node===id:!w)break}}
function graph(s){
 const b=document.getElementById('graphbox');
 if(s.svg!==null){if(svgv!==s.svg){svgv=s.svg;const v=s.svg;
   fetch('/graph.svg?v='+v).then(r=>r.text()).then(t=>{if(svgv!==v)return;
    const doc=new DOMParser().parseFromString(t,'image/svg+xml'),svg=doc.documentElement;
    if(svg.nodeName!=='svg')return;
    for(const e of [...svg.querySelectorAll('script,foreignObject,iframe,object,embed')])e.remove();
    for(const e of [...svg.querySelectorAll('a')])e.replaceWith(...e.childNodes);
    for(const e of [svg,...svg.querySelectorAll('*')])for(const at of [...e.attributes])if(/^on|href$/i.test(at.name))e.removeAttribute(at.name);
    const el=document.importNode(svg,true);el.id='graph';el.removeAttribute('width');el.removeAttribute('height');
    for(const g of el.querySelectorAll('g.node')){const t=g.querySelector('title'),m=t&&/^n:(.+)$/.exec(t.textContent);
     if(!m)continue;g.classList.add('pick');g.dataset.node=m[1];g.addEventListener('click',()=>pick(m[1]))}
    const l=document.createElement('a');l.href='/graph.svg?v='+v;l.target='_blank';l.textContent='open the picture at full size';
    b.innerHTML='';b.append(el,l)})}return}
 svgv=null;const ms={};for(const n of s.times)if(n.computed)ms[n.id]=n.ms;
 const ul=document.createElement('ul');ul.id='nodes';
 for(const n of s.nodes){const li=document.createElement('li');li.textContent=n.id+' ('+n.type+')'+(n.id in ms?' '+ms[n.id].toFixed(2)+' ms':'');
  li.dataset.node=n.id;li.className='pick';li.onclick=()=>pick(n.id);ul.appendChild(li)}
 b.innerHTML='';b.appendChild(ul)}
// the image of the node picked in the graph ($view), first among the maps, with a button that
// closes it
let viewShown=null;
function nodeView(s){
 const m=document.getElementById('main'),v=s.view;let f=document.getElementById('out-$view');
 if(!v){if(f)f.remove();viewShown=null;return}
 if(!v.node)return; // asked for, not made yet
 if(f&&(f.dataset.node!==v.node||+f.dataset.channels!==v.channels)){f.remove();f=null}
 if(!f){f=figure({name:'$view',channels:v.channels});f.dataset.node=v.node;
  const cap=f.querySelector('figcaption span');cap.textContent='node '+v.node;
  const x=document.createElement('button');x.textContent='close';x.onclick=()=>pick('');f.querySelector('figcaption').appendChild(x);
  const after=document.getElementById('view3d');m.insertBefore(f,after?after.nextSibling:m.firstChild);viewShown=null}
 f.dataset.error=v.error||'';f.title=v.error||'';
 if(viewShown!==v.version&&!v.error){f.querySelector('img').src='/view.png?v='+v.version;viewShown=v.version}}
// $time: play renders frame after frame, the next asked for when the last has finished
let playing=false,frames=0,lastFrame=0;const waiters=[];
// without /events, /api/state?after=V answers when a render newer than V is published
function rendered(v){return new Promise(r=>{waiters.push([v,r]);if(!events)poll(v)})}
function poll(v){fetch('/api/state?after='+v).then(r=>r.json()).then(s=>{show(s);if(waiters.length)poll(version)})}
function showTime(t){const i=document.getElementById('time');if(t>+i.max)i.max=Math.ceil(t);i.value=t;const v=document.getElementById('tval');v.textContent=t.toFixed(2);v.dataset.t=t}
function setPlaying(p){playing=p;const b=document.getElementById('play');b.innerHTML=p?'&#10074;&#10074; pause':'&#9654; play';b.dataset.playing=p;if(p){lastFrame=performance.now();step()}}
async function step(){
 if(!playing)return;const i=document.getElementById('time'),now=performance.now();
 let t=+i.value+Math.max(1/30,(now-lastFrame)/1000);lastFrame=now;if(t>+i.max)t=0;t=Math.round(t*1000)/1000;
 showTime(t);const v=version;await send('$time',t);await rendered(v);
 frames++;document.getElementById('play').dataset.frames=frames;
 const stop=+args.get('play');if(stop&&frames>=stop)setPlaying(false);else step()}
function show(s){
 state=s;document.getElementById('title').textContent=s.file;
 for(const p of s.params)setShown(p.name,p.value);
 if(!built&&s.params){buildParams(s.params);built=true}
 // a triplet's picker shows its colour when the three are set (not the preset's)
 const val=new Map(s.params.map(p=>[p.name,p.value]));
 for(const c of document.querySelectorAll('input[id^=color-]')){if(c===document.activeElement)continue;
  const b=c.id.slice(6),v=['r','g','b'].map(k=>+val.get(b+'_'+k));
  if(v.every(x=>x>=0))c.value=toHex(v.join(' '))}
 document.getElementById('timebox').hidden=!s.reads_time;
 if(!playing&&document.getElementById('time')!==document.activeElement)showTime(s.time);
 document.getElementById('err').textContent=s.error?'error: '+s.error:'';
 document.getElementById('cmd').textContent='wetgraph render '+q(s.file)+s.sets.map(x=>' --set '+q(x)).join('')+(s.reads_time||s.time?' --time '+s.time:'');
 const t=document.getElementById('times');t.innerHTML='';
 for(const n of s.times){const r=t.insertRow();r.insertCell().textContent=n.id;r.insertCell().textContent=n.type;r.insertCell().textContent=n.computed?n.ms.toFixed(2)+' ms':'cached'}
 graph(s);
 nodeView(s);
 // the 3D view, for a graph that makes a material (a base colour)
 if(!view3d.started()&&s.outputs.some(o=>/^(under)?basecolor$/.test(o.name)))view3d.start(document.getElementById('main'));
 viewDone=view3d.started()?view3d.update(s):null;
 // the real-time foam, for a graph that bakes foam.frag's texture (maps) beside its foam
 if(!foamView.started()&&s.outputs.some(o=>o.name==='maps')&&s.outputs.some(o=>o.name==='foam'))foamView.start(document.getElementById('main'));
 if(foamView.started()){const f=foamView.update(s);viewDone=Promise.all([viewDone,f])}
 const m=document.getElementById('main');
 for(const o of s.outputs){let f=document.getElementById('out-'+o.name);if(!f){f=figure(o);m.appendChild(f)}
  if(o.version!==version)f.querySelector('img').src='/out/'+encodeURIComponent(o.name)+'.png?v='+o.version}
 version=s.version;
 for(let k=waiters.length-1;k>=0;k--)if(waiters[k][0]<s.version){waiters[k][1]();waiters.splice(k,1)}}
function refresh(){return fetch('/api/state').then(r=>r.json()).then(show)}
document.getElementById('cmap').onchange=()=>{for(const f of document.querySelectorAll('figure'))paint(f)};
if(args.get('cmap'))document.getElementById('cmap').value=args.get('cmap');
document.getElementById('play').onclick=()=>setPlaying(!playing);
document.getElementById('time').oninput=e=>{setPlaying(false);const t=+e.target.value;showTime(t);send('$time',t)};
// ?set= and ?play= are applied unless another site sent the browser here
const own=document.querySelector('meta[name=wetgraph-address-settings]').content==='1';
const pending=own?args.getAll('set'):[],events=args.get('events')!=='0';
// the page as shown: every preview loaded (or failed) and the 3D view drawn with its maps
function settled(){
 const imgs=[...document.querySelectorAll('#main figure img')];
 return Promise.all(imgs.map(im=>im.complete?null:new Promise(r=>{im.addEventListener('load',r,{once:true});im.addEventListener('error',r,{once:true})}))).then(()=>viewDone)}
// <body data-render>: "pending" from ?set='s change until the render it asked for is published
// and shown (settled), then "done" ("error" when the render failed), so that a headless
// screenshot can wait for the new picture; without ?set=, "done" once the first state is shown.
// All of ?set='s values go in one request, so one render applies them together.
refresh().then(async()=>{
 const v=version,form=new URLSearchParams();
 for(const kv of pending){const k=kv.indexOf('=');if(k>0)form.append(kv.slice(0,k),kv.slice(k+1))}
 let asked=false;
 if([...form].length){document.body.dataset.render='pending';
  const r=await fetch('/api/set',{method:'POST',headers:{'X-Wetgraph-Token':token},body:form});
  if(r.ok)asked=true;else document.body.dataset.renderError=(await r.json()).error}
 if(own&&args.get('play'))setPlaying(true);
 if(asked)await rendered(v);
 await settled();
 document.body.dataset.render=document.body.dataset.renderError||state.error?'error':'done'});
if(events)new EventSource('/events').addEventListener('render',refresh);
